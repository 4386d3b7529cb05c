import os

import pytest


@pytest.fixture
def source_dir():
    return os.environ["SPH_SOURCE_DIR"]


@pytest.fixture
def example_points(source_dir):
    return os.path.join(source_dir, "data", "example", "points.txt")

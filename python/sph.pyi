"""Calibration of spherical coordinate measuring systems: points files and the calibration workflow."""
import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

class Error(ValueError):
    """Bad input: the library's message names the file, line and problem."""

class Points:
    """Readings of a points file (sph-points 1): the columns as NumPy arrays and the header."""
    def __init__(
        self,
        theta_deg: npt.ArrayLike,
        phi_deg: npt.ArrayLike,
        r_mm: npt.ArrayLike,
        t_s: Optional[npt.ArrayLike] = None,
        setup: Optional[npt.ArrayLike] = None,
        header: Optional[Mapping[str, Any]] = None,
        source: str = "<points>",
    ) -> None: ...
    @property
    def theta_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def phi_deg(self) -> npt.NDArray[np.float64]: ...
    @property
    def r_mm(self) -> npt.NDArray[np.float64]: ...
    @property
    def t_s(self) -> npt.NDArray[np.float64]: ...
    @property
    def setup(self) -> npt.NDArray[np.int32]: ...
    @property
    def header(self) -> Dict[str, str]: ...
    @property
    def source(self) -> str: ...
    def __len__(self) -> int: ...

class CalibrationResult:
    """A calibration run's result (sph.calibrate)."""
    @property
    def report(self) -> Dict[str, Any]: ...
    @property
    def text(self) -> str: ...
    @property
    def calibration_file(self) -> str: ...
    @property
    def parameters(self) -> Dict[str, Dict[str, Any]]: ...
    @property
    def parameter_names(self) -> List[str]: ...
    @property
    def covariance(self) -> npt.NDArray[np.float64]: ...
    @property
    def residuals_um(self) -> npt.NDArray[np.float64]: ...
    @property
    def residuals_seven_um(self) -> npt.NDArray[np.float64]: ...
    @property
    def usable(self) -> bool: ...

def read_points(path: Union[str, "os.PathLike[str]"]) -> Points: ...
def write_points(path: Union[str, "os.PathLike[str]"], points: Points) -> None: ...
def calibrate(
    path_or_points: Union[str, "os.PathLike[str]", Points],
    *,
    no_trace: bool = ...,
    effects: Union[str, Sequence[str]] = ...,
    validate: str = ...,
    sphere_form: Union[str, "os.PathLike[str]"] = ...,
    sphere_radius_mm: float = ...,
    probe_offset_mm: float = ...,
    fix: Union[str, Sequence[str]] = ...,
    prior: Union[str, Sequence[str]] = ...,
    robust_loss: str = ...,
    robust_scale_sigma: float = ...,
    max_std_um: float = ...,
    max_iterations: int = ...,
    harmonics: int = ...,
    phi_wobble_pivot_mm: float = ...,
    drift_order: int = ...,
    hold_confounded: bool = ...,
    seed: int = ...,
    coverage: float = ...,
    sphere_radius_u_um: float = ...,
    sphere_temperature_c: float = ...,
    sphere_temperature_u_c: float = ...,
    sphere_cte_per_k: float = ...,
    probe_scale_u: float = ...,
    probe_range_mm: float = ...,
    sphere_form_rms_um: float = ...,
) -> CalibrationResult: ...

def compensate(
    readings: Union[Points, npt.ArrayLike],
    calibration: Union[str, "os.PathLike[str]", CalibrationResult],
    *,
    center_mm: Optional[Sequence[float]] = None,
) -> npt.NDArray[np.float64]: ...

class MeasurementResult:
    """A sphere measurement's result (sph.measure)."""
    @property
    def report(self) -> Dict[str, Any]: ...
    @property
    def text(self) -> str: ...
    @property
    def points_mm(self) -> npt.NDArray[np.float64]: ...

def measure(
    path: Union[str, "os.PathLike[str]"],
    *,
    calibration: Union[str, "os.PathLike[str]"] = ...,
    xyz: bool = ...,
    subtract_sphere_form: bool = ...,
    setup: int = ...,
    uncertainty_samples: int = ...,
    seed: int = ...,
    max_dilution: float = ...,
    noise_um: float = ...,
    noise_floor_draws: int = ...,
    coverage: float = ...,
    mc_max_trials: int = ...,
    mc_batch_trials: int = ...,
    mc_digits: int = ...,
    mc_max_points: int = ...,
) -> MeasurementResult: ...

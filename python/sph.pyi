"""Calibration of spherical coordinate measuring systems: points files, the calibration and measurement
workflows, simulated readings of a known machine and the Monte Carlo study."""
import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

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
    def dcc(self, settings: Optional[Union[str, "os.PathLike[str]"]] = None, **keys: Union[str, List[str]]) -> str: ...
    @property
    def why_not_usable(self) -> List[str]: ...

def read_points(path: Union[str, "os.PathLike[str]"]) -> Points: ...
def write_points(path: Union[str, "os.PathLike[str]"], points: Points) -> None: ...
def calibrate(
    path_or_points: Union[str, "os.PathLike[str]", Points],
    *,
    no_trace: bool = ...,
    effects: Union[str, Sequence[str]] = ...,
    validate: str = ...,
    compare: str = ...,
    sphere_form: Union[str, "os.PathLike[str]", Sequence[Union[str, "os.PathLike[str]"]]] = ...,
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
    accept_rejected: bool = ...,
    target_u: Union[str, Sequence[str]] = ...,
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
    def dcc(self, settings: Optional[Union[str, "os.PathLike[str]"]] = None, **keys: Union[str, List[str]]) -> str: ...

def measure(
    path_or_points: Union[str, "os.PathLike[str]", Points],
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

# A value in the app's words ("2,0,0"), or numbers: (2, 0, 0).
_Text = Union[str, Sequence[float]]
# A repeatable option: one value or a sequence of them.
_Texts = Union[_Text, Sequence[_Text]]

def simulate(
    *,
    alpha_deg: float = ...,
    a_mm: float = ...,
    beta_deg: float = ...,
    b_mm: float = ...,
    epsilon_deg: float = ...,
    c_mm: float = ...,
    d_prime_mm: float = ...,
    sphere_radius_mm: float = ...,
    probe_offset_mm: float = ...,
    theta_steps: int = ...,
    phi_steps: int = ...,
    angles: Union[str, "os.PathLike[str]"] = ...,
    noise_r_um: float = ...,
    noise_theta_arcsec: float = ...,
    noise_phi_arcsec: float = ...,
    center_mm: _Texts = ...,
    seed: int = ...,
    sample_period_s: float = ...,
    effect_arcsec: Union[str, Sequence[str]] = ...,
    effect_um: Union[str, Sequence[str]] = ...,
    probe_range_mm: float = ...,
    phi_wobble_pivot_mm: float = ...,
    mount_rotation_deg: Union[str, Sequence[str]] = ...,
    mount_unknown: Union[str, int, Sequence[Union[str, int]]] = ...,
    other_sphere_radius_mm: Union[str, Sequence[str]] = ...,
    form_um: _Texts = ...,
    form_flat_um: _Texts = ...,
    form_bump_um: _Texts = ...,
    scan_order: Union[str, Sequence[str]] = ...,
    outlier_fraction: float = ...,
    outlier_um: float = ...,
) -> Tuple[Points, Dict[str, Any]]:
    """Readings of a known machine (sph_simulate): the points and the truth (sph_simulate --truth)."""

class MonteCarloResult:
    """A Monte Carlo study's result (sph.monte_carlo)."""
    @property
    def report(self) -> Dict[str, Any]: ...
    @property
    def trials(self) -> Dict[str, npt.NDArray[Any]]: ...

def monte_carlo(
    *,
    trials: int = ...,
    eccentricities_mm: Union[float, Sequence[float]] = ...,
    direction: _Text = ...,
    random_direction: bool = ...,
    setups: int = ...,
    seed: int = ...,
    threads: int = ...,
    max_std_um: float = ...,
    table3: bool = ...,
    table3_calibration_e_mm: float = ...,
    alpha_deg: float = ...,
    a_mm: float = ...,
    beta_deg: float = ...,
    b_mm: float = ...,
    epsilon_deg: float = ...,
    c_mm: float = ...,
    d_prime_mm: float = ...,
    sphere_radius_mm: float = ...,
    probe_offset_mm: float = ...,
    theta_steps: int = ...,
    phi_steps: int = ...,
    angles: Union[str, "os.PathLike[str]"] = ...,
    noise_r_um: float = ...,
    noise_theta_arcsec: float = ...,
    noise_phi_arcsec: float = ...,
) -> MonteCarloResult:
    """The Monte Carlo study of the calibration (sph_montecarlo): its report and every trial's estimates."""

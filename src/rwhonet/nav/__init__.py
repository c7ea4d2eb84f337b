"""2D positioning through a GNSS outage: a navigation filter and its calibration checks.

Beyond the paper (whose errors are distances travelled). Pure domain code:
arrays in, arrays out.

- :mod:`rwhonet.nav.filter`: an extended Kalman filter over position, heading,
  gyro bias and scale, odometry scale, the wheel yaw's scale, bias per metre
  and load-transfer term, and the GNSS receiver's drift; propagated each
  second by an odometry model's distance and the yaw of the gyro, the rear
  wheels, or both fused; updated by GNSS course and position while they are
  valid (:func:`run`).
- :mod:`rwhonet.nav.outage`: one run per outage window, calibrated on the
  seconds before it (:func:`run_outage`, :func:`window_inputs`).
- :mod:`rwhonet.nav.sensors`: the filter's noise from the sensors' stated error models.
- :mod:`rwhonet.nav.coverage`: whether the predicted uncertainty is honest
  (coverage of 1σ/2σ regions, negative log-likelihood, CRSE's predicted spread).
"""

from rwhonet.nav.coverage import (
    ELLIPSE_CONTENT,
    MIN_T2_WINDOWS,
    SIGMA_CONTENT,
    coverage_1d,
    coverage_2d,
    crse_coverage,
    crse_prediction,
    fit_t2,
    fit_t2_scale,
    mahalanobis_sq,
    nll_2d,
    t2_quantile,
    t2_radius_nll,
)
from rwhonet.nav.filter import (
    CONTROLS,
    STATE,
    NavConfig,
    NavInputs,
    NavStart,
    NavTrack,
    config_from_params,
    run,
)
from rwhonet.nav.outage import OutageResult, run_outage, window_inputs
from rwhonet.nav.sensors import GnssSpec, GyroSpec, WheelSpec

__all__ = [
    "CONTROLS",
    "ELLIPSE_CONTENT",
    "MIN_T2_WINDOWS",
    "SIGMA_CONTENT",
    "STATE",
    "GnssSpec",
    "GyroSpec",
    "NavConfig",
    "NavInputs",
    "NavStart",
    "NavTrack",
    "OutageResult",
    "WheelSpec",
    "config_from_params",
    "coverage_1d",
    "coverage_2d",
    "crse_coverage",
    "crse_prediction",
    "fit_t2",
    "fit_t2_scale",
    "t2_radius_nll",
    "mahalanobis_sq",
    "nll_2d",
    "run",
    "run_outage",
    "t2_quantile",
    "window_inputs",
]

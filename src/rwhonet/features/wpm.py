"""The wheel-odometry physics model (WPM, paper Eqs. 6-10) and the label (Eq. 11).

Per second, the rear axle's displacement is the mean of the two rear wheels'
rolled distances, each wheel angle times that wheel's calibrated effective
rolling radius (m/rad)::

    x_whr = (r_rl * theta_rl + r_rr * theta_rr) / 2          (Eqs. 6-10)

Two ways to get the wheel angle ``theta`` of a second (``label.wpm_mode``):

- ``integrated`` (default): the trapezoid integral of the ten 10 Hz samples
  over the second (:func:`rwhonet.features.seconds.integrate_per_second`),
  i.e. Eq. 10's integral taken at the data's full rate.
- ``reference``: the authors' code: one wheel-speed sample per second (the one
  at the end of the second) times 1 s. Equal to ``integrated`` at constant
  speed; under acceleration ``a`` it is off by ``a / 2`` metres per second
  (the end sample is the fastest one of an accelerating second).

Label sign: ``label_m = disp_gnss_m - disp_wpm_m``. The paper's Eq. 11 writes
``x_whr - x_GNSS``, but the authors' code and every results table use
``GNSS - WPM``, so that the model output is the correction to *add* to the
WPM displacement (``x_GNSS = x_whr + y``). With this sign a calibrated radius
that is too small (WPM under-reads) gives a positive label: radius 2 % short
-> label +2 % of the distance. The "-2 %" of the same situation holds only
with Eq. 11's ``WPM - GNSS`` sign.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

WpmMode = Literal["integrated", "reference"]
WPM_MODES: tuple[str, ...] = ("integrated", "reference")
# The authors' code multiplies one wheel-speed sample by a one-second time step.
REFERENCE_STEP_S = 1.0


def wheel_angle_rad(
    angle_integrated_rad: np.ndarray, omega_end_rad_s: np.ndarray, mode: WpmMode
) -> np.ndarray:
    """Select the per-second wheel angle the WPM uses.

    Args:
        angle_integrated_rad: trapezoid-integrated wheel angle per second, rad.
        omega_end_rad_s: wheel speed sampled at the end of each second, rad/s.
        mode: ``integrated`` or ``reference`` (module docstring).

    Returns:
        Wheel angle per second, rad.

    Raises:
        ValueError: for an unknown mode.
    """
    if mode == "integrated":
        return np.asarray(angle_integrated_rad, dtype=np.float64)
    if mode == "reference":
        return np.asarray(omega_end_rad_s, dtype=np.float64) * REFERENCE_STEP_S
    raise ValueError(f"wpm mode must be one of {WPM_MODES}, got {mode!r}")


def wpm_displacement_m(
    angle_rl_rad: np.ndarray, angle_rr_rad: np.ndarray, r_rl_m: float, r_rr_m: float
) -> np.ndarray:
    """Return the WPM displacement of the rear axle per second (paper Eqs. 6-10).

    The paper averages the wheel speeds (Eq. 6) and multiplies by one radius
    (Eq. 8); with one calibrated radius per rear wheel (as the authors' code
    does) the average is taken after scaling, which reduces to the paper's
    form when the radii are equal.

    Args:
        angle_rl_rad: rear-left wheel angle per second, rad.
        angle_rr_rad: rear-right wheel angle per second, rad.
        r_rl_m: effective rolling radius of the rear-left wheel, m/rad.
        r_rr_m: effective rolling radius of the rear-right wheel, m/rad.

    Returns:
        Displacement per second, metres (float64).
    """
    return 0.5 * (
        r_rl_m * np.asarray(angle_rl_rad, np.float64)
        + r_rr_m * np.asarray(angle_rr_rad, np.float64)
    )


def radius_corrected(
    pred_m: np.ndarray,
    angle_rl_rad: np.ndarray,
    angle_rr_rad: np.ndarray,
    radii: tuple[float, float],
    source_radii: tuple[float, float],
) -> np.ndarray:
    """A correction to the WPM with ``radii``, restated as one to the WPM with ``source_radii``.

    A model whose recipe refitted the rear radii (``radius+G``) predicts what the WPM with
    its own radii misses; the label is what the source-calibrated WPM misses, so the
    difference of the two WPMs is added: ``pred + WPM(radii) − WPM(source_radii)``.

    Args:
        pred_m: the model's correction per second, metres.
        angle_rl_rad: rear-left wheel angle per second, rad.
        angle_rr_rad: rear-right wheel angle per second, rad.
        radii: the rear radii the model corrects, m/rad.
        source_radii: the source calibration's rear radii, m/rad.

    Returns:
        The label prediction per second, metres (float64).
    """
    return (
        np.asarray(pred_m, np.float64)
        + wpm_displacement_m(angle_rl_rad, angle_rr_rad, *radii)
        - wpm_displacement_m(angle_rl_rad, angle_rr_rad, *source_radii)
    )


def label_m(disp_gnss_m: np.ndarray, disp_wpm_m: np.ndarray) -> np.ndarray:
    """Return the learning target per second: GNSS minus WPM displacement (Eq. 11, code's sign).

    Args:
        disp_gnss_m: GNSS displacement per second, metres.
        disp_wpm_m: WPM displacement per second, metres.

    Returns:
        ``disp_gnss_m - disp_wpm_m`` in metres: what must be added to the WPM
        displacement to match GNSS (see the module docstring for the sign).
    """
    return np.asarray(disp_gnss_m, np.float64) - np.asarray(disp_wpm_m, np.float64)

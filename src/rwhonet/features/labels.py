"""The per-second samples of a segment: WPM displacement, label and scaled features.

Paper Eqs. 6-11 and 14-15: from a segment's raw per-second quantities
(:mod:`rwhonet.features.seconds`), the calibrated rear radii
(:mod:`rwhonet.features.calibration`) and the fitted scaler
(:mod:`rwhonet.features.scaling`), one row per second in the samples contract
(:data:`rwhonet.contracts.SAMPLE_COLUMNS`).
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa

from rwhonet import contracts as k
from rwhonet.features.calibration import Calibration
from rwhonet.features.scaling import MinMaxScaler
from rwhonet.features.seconds import SegmentSeconds
from rwhonet.features.wpm import WPM_MODES, label_m, wheel_angle_rad, wpm_displacement_m


def sample_table(
    sec: SegmentSeconds, calibration: Calibration, scaler: MinMaxScaler, wpm_mode: str
) -> pa.Table:
    """Build one segment's samples (the label stage's output rows) as an Arrow table.

    Arrow rather than pandas: the table goes to Parquet without a DataFrame's
    per-column conversions; ``table.to_pandas()`` gives the DataFrame.

    Args:
        sec: the segment's raw per-second quantities.
        calibration: rear radii for the WPM.
        scaler: fitted min-max scaler.
        wpm_mode: ``integrated`` or ``reference``: the WPM the label is taken against
            (both modes' displacements are written, for the baselines).

    Returns:
        Table with columns :data:`rwhonet.contracts.SAMPLE_COLUMNS`: float64 ``t_s``, metres
        and radians (``gyro_yaw_rad`` NaN without a yaw rate), ``backwards`` 0.0 / 1.0,
        float32 features, string ``scenario``.
    """
    angles = {
        mode: (
            wheel_angle_rad(sec.angle_rl_rad, sec.omega_end_rl_rad_s, mode),
            wheel_angle_rad(sec.angle_rr_rad, sec.omega_end_rr_rad_s, mode),
        )
        for mode in WPM_MODES
    }
    disp = {
        mode: wpm_displacement_m(rl, rr, calibration.r_rl_m, calibration.r_rr_m)
        for mode, (rl, rr) in angles.items()
    }
    disp_wpm = disp[wpm_mode]
    # Transposed copy: each feature column becomes one contiguous float32 array.
    features = np.ascontiguousarray(scaler.transform(sec.wheels_rad_s).T)
    columns = {
        k.T_S: sec.t_s,
        k.DISP_GNSS_M: sec.disp_gnss_m,
        k.DISP_WPM_M: disp_wpm,
        k.LABEL_M: label_m(sec.disp_gnss_m, disp_wpm),
        k.DISP_WPM_INTEGRATED_M: disp["integrated"],
        k.DISP_WPM_REFERENCE_M: disp["reference"],
        k.ANGLE_RL_RAD: angles[wpm_mode][0],
        k.ANGLE_RR_RAD: angles[wpm_mode][1],
        k.LAT_DEG: sec.lat_deg,
        k.LON_DEG: sec.lon_deg,
        k.GYRO_YAW_RAD: sec.gyro_yaw_rad,
        k.BACKWARDS: sec.backwards.astype(np.float64),
        **dict(zip(k.FEATURE_COLUMNS, features, strict=True)),
        k.SCENARIO: pa.array(sec.scenario, type=pa.string()),
    }
    arrays = [pa.array(values) for values in columns.values()]
    # Non-nullable: no value is ever missing, and Parquet then stores no definition levels.
    schema = pa.schema(
        [pa.field(name, a.type, nullable=False) for name, a in zip(columns, arrays, strict=True)]
    )
    return pa.Table.from_arrays(arrays, schema=schema)

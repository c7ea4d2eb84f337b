"""From GNSS-valid segments to model-ready per-second samples.

- :mod:`~rwhonet.features.seconds`: how a second is cut from 10 Hz rows; GNSS
  displacement, wheel angles, the 40 wheel-speed features and scenario tags per second.
- :mod:`~rwhonet.features.wpm`: the wheel-odometry physics model (paper Eqs. 6-10),
  the label (Eq. 11, GNSS - WPM), and a correction restated from one radius to another.
- :mod:`~rwhonet.features.calibration`: effective rear-wheel rolling radii.
- :mod:`~rwhonet.features.scaling`: min-max input scaling fitted on source_train.
- :mod:`~rwhonet.features.labels`: one segment's samples table (label, WPM, scaled inputs).
- :mod:`~rwhonet.features.sequences`: sequences of seconds that never cross a segment,
  and labelled windows (what the networks train on).
- :mod:`~rwhonet.features.samples`: labelled segments stacked into the models' arrays.
- :mod:`~rwhonet.features.deadreckoning`: 2D dead reckoning from the rear wheels.

The ``label`` stage ties seconds, calibration, scaling and labels together; the
model stages and ``rwhonet recalibrate`` stack the samples.
Submodules are imported explicitly (``from rwhonet.features.sequences import
sequences``) so a model import does not pull in pyproj or pandas.
"""

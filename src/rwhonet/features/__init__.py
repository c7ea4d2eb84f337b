"""From GNSS-valid segments to model-ready per-second samples.

- :mod:`~rwhonet.features.seconds`: how a second is cut from 10 Hz rows; GNSS
  displacement, wheel angles, the 40 wheel-speed features and scenario tags per second.
- :mod:`~rwhonet.features.wpm`: the wheel-odometry physics model (paper Eqs. 6-10)
  and the label (Eq. 11, GNSS - WPM).
- :mod:`~rwhonet.features.calibration`: effective rear-wheel rolling radii.
- :mod:`~rwhonet.features.scaling`: min-max input scaling fitted on source_train.
- :mod:`~rwhonet.features.windows`: sequences of seconds that never cross a segment.
- :mod:`~rwhonet.features.samples`: the ``label`` stage that ties them together.

Submodules are imported explicitly (``from rwhonet.features.windows import
sequences``) so a model import does not pull in pyproj or pandas.
"""

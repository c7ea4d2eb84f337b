"""Drive data: readers, schema, GNSS quality, the per-drive checks, segments.

- :mod:`~rwhonet.data.canonical`: the canonical column names readers produce.
- :mod:`~rwhonet.data.iovnbd`, :mod:`~rwhonet.data.columnmap`: the readers (IO-VNBD
  "V-" files, any CSV through a column map), on :mod:`~rwhonet.data.csvio`'s
  streamed numeric CSV reading.
- :mod:`~rwhonet.data.drivefile`: one drive file: its reader, size limit, scenario
  sidecar (:mod:`~rwhonet.data.scenarios`) and canonical table.
- :mod:`~rwhonet.data.schema`: the pandera schema of a canonical drive.
- :mod:`~rwhonet.data.quality`: the GNSS-quality policy and the valid segments.
- :mod:`~rwhonet.data.plausibility`: units, signs, stuck or silent wheel sensors,
  swapped coordinates, as arrays and runs of rows.
- :mod:`~rwhonet.data.drivechecks`: everything ``validate`` checks on one drive,
  as problems a user can act on (:mod:`~rwhonet.data.problems` keeps them short).
- :mod:`~rwhonet.data.stream`: drive rows read from a stream as they arrive.
"""

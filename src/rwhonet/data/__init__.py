"""Drive data: readers, schema, GNSS quality, the per-drive checks, segments.

- :mod:`~rwhonet.data.canonical`: the canonical column names readers produce.
- :mod:`~rwhonet.data.iovnbd`, :mod:`~rwhonet.data.columnmap`: the readers (IO-VNBD
  "V-" files, any CSV through a column map), on :mod:`~rwhonet.data.csvio`'s
  streamed numeric CSV reading.
- :mod:`~rwhonet.data.drivefile`: one drive file: its reader, size limit, scenario
  sidecar (:mod:`~rwhonet.data.scenarios`) and canonical table.
- :mod:`~rwhonet.data.compressed`: drive files kept compressed (gzip, bzip2, xz, zstd, a
  ZIP archive of one), told by their bytes, and a drive's id without the suffix.
- :mod:`~rwhonet.data.columnar`: drive files kept as columnar tables (Parquet, Arrow IPC /
  Feather, a folder of Parquet part files), told by their bytes, read as the CSV they hold
  a record batch at a time.
- :mod:`~rwhonet.data.fleetfile`: one 10 Hz file (or table) holding many drives, a column
  naming each row's drive (a column map's ``drive`` key), split into its drives.
- :mod:`~rwhonet.data.fastfile`: a 10 Hz layout logged faster (20-100 Hz), or at a rate of
  the logger's own (9.98 Hz), read as streams and resampled onto the grid.
- :mod:`~rwhonet.data.schema`: the pandera schema of a canonical drive.
- :mod:`~rwhonet.data.quality`: the GNSS-quality policy and the valid segments.
- :mod:`~rwhonet.data.fixes`: what counts as a GNSS fix (not (0, 0), enough satellites).
- :mod:`~rwhonet.data.fixstatus`: a receiver's fix status in a column of its own (GGA
  quality, u-blox ``fixType``, NavSatStatus, a flag): the positions that are no fix.
- :mod:`~rwhonet.data.fixtimes`: when each fix was taken: the receiver's epochs (its own
  time, or the regular grid a logger's arrival stamps scatter about, where the wheel
  speeds say so) or the stamps.
- :mod:`~rwhonet.data.fixlag`: how late the fixes run against the wheel speeds' clock (a
  receiver's latency), from the wheels with tyre slip told apart; reported, or moved out
  (``data.gnss_lag``).
- :mod:`~rwhonet.data.plausibility`: units, signs, stuck or silent wheel sensors,
  swapped coordinates, as arrays and runs of rows.
- :mod:`~rwhonet.data.drivechecks`: everything ``validate`` checks on one drive,
  as problems a user can act on (:mod:`~rwhonet.data.problems` keeps them short).
- :mod:`~rwhonet.data.incremental`: drive rows read from a stream as they arrive.
- :mod:`~rwhonet.data.droprows`: rows a logger wrote twice or without a wheel speed,
  dropped, and the file's row numbers kept for every message.
- :mod:`~rwhonet.data.heldfixes`: fixes a 10 Hz file holds from a slower receiver,
  found and placed along the wheels' path.
- :mod:`~rwhonet.data.headers`, :mod:`~rwhonet.data.timebase`: header names as users
  write them; a drive's clock (midnight rollover, each row's slot on the grid, each run
  after a logger's restart on its own phase).
- :mod:`~rwhonet.data.texttime`: time columns written as text (ISO 8601, ``hh:mm:ss``), and
  a date in a column of its own.
- :mod:`~rwhonet.data.packed`: NMEA's numbers packed from parts (``ddmm.mmmm`` angles,
  ``hhmmss.ss`` times of day) and its hemisphere letters.
- :mod:`~rwhonet.data.vbo`: Racelogic VBOX files read as the CSV they stand for.
- :mod:`~rwhonet.data.wheelunits`: the units a wheel speed is logged in, angular or the
  wheel's circumferential speed (divided by the car's nominal tyre radius).
- :mod:`~rwhonet.data.wheelpulses`: a wheel's pulse counter (the ABS unit's count of the
  tone wheel's teeth) as its angular speed, once its samples are in time order.
- :mod:`~rwhonet.data.glitches`: wheel speeds that change faster than any tyre can.
- :mod:`~rwhonet.data.fileparts`: a stream a logger split across files in time (rotated
  CSVs, NMEA, UBX and CAN logs), joined, each sample keeping its file and row.
- :mod:`~rwhonet.data.robust`: a robust scale (the normal-scaled MAD) and a running
  trapezoid integral, scipy's arithmetic without scipy's import.
- Streams (docs/readers.md): :mod:`~rwhonet.data.streams` resamples timestamped
  sensor streams onto the 10 Hz grid; they come from :mod:`~rwhonet.data.comma2k19`
  (openpilot processed logs), :mod:`~rwhonet.data.mdf4` (ASAM MDF4, via asammdf; a ROS 1
  bag's topics, via rosbags, by :mod:`~rwhonet.data.rosbag`; one a recorder left without
  its index, or damaged, record by record, by :mod:`~rwhonet.data.bagscan`, a ROS 2 bag's
  MCAP file left without its summary, or damaged, by :mod:`~rwhonet.data.mcapscan`, its
  sqlite3 file cut short or damaged, page by page, by :mod:`~rwhonet.data.db3scan`, through
  the write-ahead log a recorder stopped before its checkpoint left beside it, read by
  :mod:`~rwhonet.data.sqlitewal`) or
  :mod:`~rwhonet.data.streamcsv` (one CSV per stream), named by a signal map
  (:mod:`~rwhonet.data.signalmap`); a receiver's NMEA 0183 log among the stream CSVs is
  read by :mod:`~rwhonet.data.nmea`, a u-blox receiver's binary log (UBX NAV-PVT) by
  :mod:`~rwhonet.data.ubx`, a NovAtel receiver's logs (BESTPOS, ASCII or binary) by
  :mod:`~rwhonet.data.novatel`, a Septentrio receiver's binary log (SBF PVTGeodetic) by
  :mod:`~rwhonet.data.sbf`, a phone's GnssLogger log (its Fix or NMEA records) by
  :mod:`~rwhonet.data.gnsslogger`, a gpsd client's log (``gpspipe -w``'s JSON reports) by
  :mod:`~rwhonet.data.gpsdjson`, a GPS track in GPX (a phone's or handheld's logger) by
  :mod:`~rwhonet.data.gpx`; a bus tool's log of raw CAN frames (candump, ASC,
  BLF, TRC) by :mod:`~rwhonet.data.canlog` (a Vector BLF's objects parsed at once by
  :mod:`~rwhonet.data.blf`, an ASC's lines by :mod:`~rwhonet.data.asc`, a PEAK TRC's
  by :mod:`~rwhonet.data.trc`), laid out as an MDF4 bus log for the map's DBC.
  :mod:`~rwhonet.data.bytescan` finds things in a text log's bytes at once, for the NMEA,
  candump, ASC and TRC readers; :mod:`~rwhonet.data.keptframes` keeps, a part of a log at a
  time, only the frames of the messages the map's signals are in; an MDF4 bus log's frames
  (a CANedge's, a Vector logger's) are read so by :mod:`~rwhonet.data.mdfframes`.
- :mod:`~rwhonet.data.leftout`: drives ingest or validate refused, left out of a run where
  ``data.refused_drives: leave_out`` says so, and named in every manifest and report.
- :mod:`~rwhonet.data.sampleorder`: a stream's samples written twice dropped, and those
  written out of time order put in order where that is all that is wrong; a 10 Hz file's
  rows out of time order too (``rows_in_time_order``), and a table's clock set back while
  the car drove on put on one clock (``clock_set_back``, ``clock_steps``).
"""

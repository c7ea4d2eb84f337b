"""A bus tool's log of raw CAN frames (candump, ASC, BLF, TRC; rwhonet.data.canlog) decoded
with the signal map's DBC as an MDF4 bus log is (rwhonet.data.mdf4)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.canlog import is_can_log_name, read_frames
from rwhonet.data.keptframes import FrameFilter
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.errors import InputError
from support.canlog import (
    DBC,
    J1939_DBC,
    J1939_FLAG,
    J1939_SENT,
    SIGNALS,
    assert_same_frames,
    can_frames,
    write_bus_log,
)
from support.realminute import RAV4_RADIUS_M
from support.serving import wavy_drive

RADIUS_M = 0.31
NAME = "data.signal_maps.bus.signals"
T0_S = 1_700_000_000.0  # the logging computer's Unix clock


def _signals() -> dict[str, ColumnSpec]:
    return {k: ColumnSpec(**v) for k, v in SIGNALS.items()}


def test_names():
    assert is_can_log_name("bus.log") and is_can_log_name("d.ASC") and is_can_log_name("x.blf")
    assert is_can_log_name("bus.log.gz") and is_can_log_name("a.trc")
    assert not is_can_log_name("drive.mf4") and not is_can_log_name("gps.nmea")


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf", ".trc"])
def test_each_bus_tool_s_log_gives_the_drive_s_streams(tmp_path, suffix):
    """Frames written by python-can's writer of each format: the wheel speeds within half
    the DBC's 0.01 km/h, the fixes within 1e-7 deg, the satellite count at the fixes'
    times; the stamps as the log keeps them (ASC: from the measurement's start)."""
    df = wavy_drive(30.0)
    stamps, ids, data = can_frames(df, RADIUS_M, T0_S)
    log = write_bus_log(stamps, ids, data, tmp_path / f"bus{suffix}")
    (tmp_path / "bus.dbc").write_text(DBC)
    streams = read_mdf4(log, _signals(), RADIUS_M, NAME, log.name, [str(tmp_path / "bus.dbc")])
    (wheels,) = streams.wheels
    t = df[c.T_S].to_numpy() - df[c.T_S].iloc[0]
    start = 0.0 if suffix == ".asc" else T0_S
    np.testing.assert_allclose(wheels.t_s - start, t, rtol=0, atol=1e-6)
    step = 0.01 / 3.6 / RADIUS_M  # one count of the DBC's scale, rad/s
    for w in c.WHEELS:
        np.testing.assert_allclose(wheels.channels[w], df[w], rtol=0, atol=step / 2 + 1e-9)
    fix = df[c.LAT_DEG].notna().to_numpy()
    np.testing.assert_allclose(streams.gnss.t_s - start, t[fix] + 0.002, rtol=0, atol=1e-6)
    np.testing.assert_allclose(streams.gnss.channels[c.LAT_DEG], df.loc[fix, c.LAT_DEG], atol=6e-8)
    np.testing.assert_array_equal(streams.gnss.channels[c.N_SATS], df.loc[fix, c.N_SATS])
    said = " ".join(streams.notes)
    assert f"{log.name}: raw CAN frames decoded with bus.dbc: 3 of the log's 3 frame IDs" in said
    assert f"{log.name}: {len(ids)} data frames on 1 bus(es)" in said
    assert ("Unix time" in streams.clock) == (suffix != ".asc")
    assert wheels.sources[c.T_S] == "frame time stamp" and not streams.changed


@pytest.mark.parametrize("suffix", [".asc", ".trc"])
def test_a_text_log_in_windows_code_page_reads_as_the_same_log_in_ascii(tmp_path, suffix):
    """A bus tool's text log written on a German Windows installation (cp1252: a comment
    with umlauts, CRLF line ends): python-can, decoding with a UTF-8 locale, refused it
    whole; read in cp1252, its frames are those of the same log in ASCII."""
    stamps, ids, data = can_frames(wavy_drive(10.0), RADIUS_M, T0_S)
    plain = write_bus_log(stamps, ids, data, tmp_path / f"plain{suffix}")
    comment = "// Prüfstand, Straße" if suffix == ".asc" else ";   Prüfstand, Straße"
    lines = plain.read_text().splitlines()
    lines.insert(2 if suffix == ".asc" else 1, comment)  # among the header's lines
    german = tmp_path / f"german{suffix}"
    german.write_bytes("\r\n".join(lines).encode("cp1252") + b"\r\n")
    with pytest.raises(UnicodeDecodeError):
        german.read_bytes().decode("utf-8")
    got, want = read_frames(german, german.name), read_frames(plain, plain.name)
    assert got.t_s.size == len(ids)
    if suffix == ".trc":  # a TRC's frames are named by their lines: the comment is above
        np.testing.assert_array_equal(got.rows, want.rows + 1)
        got = dataclasses.replace(got, rows=want.rows)
    assert_same_frames(got, want)


CANDUMP = """\
(1436509052.249713) can0 0AA#1A2B3C4D5E6F7081
(1436509052.250000) can0 0AA#1A2B3C4D5E6F7082 R
(1436509052.250112) can1 18FEF100##31122334455667788990A0B0C0D0E0F10
(1436509052.251000) can0 20000080#0000000000000000
(1436509052.252000) can0 123#R
(1436509052.253000) can1 7FF#
(1436509052.254000) can0 12345678#DEADBEEF T
(1436509052.255000) vcan0 001##0AABB
"""


def test_candump_lines_read_as_python_can_reads_them(tmp_path):
    """Standard and extended identifiers, a CAN FD frame (``##`` and its flags), a frame of
    no bytes, the direction after the data: the frames python-can's own candump reader
    gives, bit for bit; its error and remote frames are passed over and counted."""
    import can

    path = tmp_path / "bus.log"
    path.write_text(CANDUMP)
    frames = read_frames(path, "bus.log")
    with can.LogReader(path) as reader:
        want = [m for m in reader if not m.is_error_frame and not m.is_remote_frame]
    assert frames.t_s.tolist() == [m.timestamp for m in want]
    assert frames.ids.tolist() == [m.arbitration_id for m in want]
    assert frames.extended.tolist() == [m.is_extended_id for m in want]
    got = [bytes(row[:n]) for row, n in zip(frames.data, frames.length, strict=True)]
    assert got == [bytes(m.data) for m in want]
    assert frames.buses == ["can0", "can1", "vcan0"]
    assert frames.channel.tolist() == [1, 1, 2, 2, 1, 3]
    assert frames.data.shape == (6, 64)  # an FD frame among them
    assert frames.passed == "1 error frames, 1 remote frames"


def test_damaged_candump_lines_are_passed_over_and_counted(tmp_path):
    """A line cut short, data of odd length or no hex, an identifier of neither 3 nor 8
    digits, a stamp that is no number, an FD frame of a length FD has none of or a flags
    digit that is no hex, a CAN XL frame, a line that is no frame: passed over, counted
    with the first; the rest read."""
    lines = [
        "(1.000000) can0 0AA#0102030405060708",
        "(1.001000) can0 0AA#010203040506070",  # line 2: cut short (odd)
        "(1.002000) can0 0AA#01020304050607ZZ",  # 3: no hex
        "(1.003000) can0 0AAA#0102",  # 4: a 4-digit identifier
        "(1.0x4000) can0 0AA#0102",  # 5: a stamp that is no number
        "(1.005000) can0 0AA##1" + "00" * 10,  # 6: FD has no 10-byte frame
        "(1.006000) can0 0AA###80:00:00:00000000:0102",  # CAN XL
        "(1.007000) can0 0AA##Z0102",  # 8: an FD flags digit that is no hex
        "garbage",  # 9: no frame
        "",
        "(1.008000)  an0 0AA#0102",  # 11: a byte of the interface's name lost
        "(1.010000) can0 0AA#0807060504030201",
    ]
    path = tmp_path / "bus.log"
    path.write_text("\n".join(lines) + "\n")
    frames = read_frames(path, "bus.log")
    np.testing.assert_allclose(frames.t_s, [1.0, 1.01])
    assert frames.data[1].tolist() == [8, 7, 6, 5, 4, 3, 2, 1]
    assert "1 CAN XL frames" in frames.passed
    assert "6 lines damaged (first at line 2)" in frames.passed
    assert "2 lines that are no frame (first at line 9)" in frames.passed
    assert frames.buses == ["can0"]


def test_a_log_without_a_dbc_or_without_data_frames_is_refused(tmp_path):
    df = wavy_drive(10.0)
    log = write_bus_log(*can_frames(df, RADIUS_M, T0_S), tmp_path / "bus.log")
    with pytest.raises(InputError) as err:
        read_mdf4(log, _signals(), RADIUS_M, NAME, "bus.log")
    problem = err.value.problems[0]
    assert problem.file == "bus.log" and "give data.signal_maps.bus.dbc" in problem.fix
    empty = tmp_path / "errors.log"
    empty.write_text("(1.0) can0 20000080#0000000000000000\n")
    (tmp_path / "bus.dbc").write_text(DBC)
    with pytest.raises(InputError) as err:
        read_mdf4(empty, _signals(), RADIUS_M, NAME, "errors.log", [str(tmp_path / "bus.dbc")])
    said = str(err.value)
    assert "errors.log: expected CAN data frames, as candump -l writes them" in said
    assert "found none (1 error frames)" in said


def test_a_damaged_blf_is_refused_naming_the_file(tmp_path):
    df = wavy_drive(10.0)
    log = write_bus_log(*can_frames(df, RADIUS_M, T0_S), tmp_path / "bus.blf")
    data = log.read_bytes()
    log.write_bytes(data[:200] + bytes(range(256)) * 4 + data[1300:])
    (tmp_path / "bus.dbc").write_text(DBC)
    with pytest.raises(InputError) as err:
        read_mdf4(log, _signals(), RADIUS_M, NAME, "bus.blf", [str(tmp_path / "bus.dbc")])
    problem = err.value.problems[0]
    assert problem.file == "bus.blf" and "a BLF CAN log python-can reads" in problem.expected


# Toyota's wheel-speed message as opendbc (commaai/opendbc, MIT licence) defines it in its
# Toyota DBCs: four big-endian (Motorola) 16-bit counts of 0.01 km/h, less 67.67 km/h
TOYOTA_WHEELS = """VERSION ""

NS_ :

BS_:

BU_: XXX

BO_ 170 WHEEL_SPEEDS: 8 XXX
 SG_ WHEEL_SPEED_FR : 7|16@0+ (0.01,-67.67) [0|250] "km/h" XXX
 SG_ WHEEL_SPEED_FL : 23|16@0+ (0.01,-67.67) [0|250] "km/h" XXX
 SG_ WHEEL_SPEED_RR : 39|16@0+ (0.01,-67.67) [0|250] "km/h" XXX
 SG_ WHEEL_SPEED_RL : 55|16@0+ (0.01,-67.67) [0|250] "km/h" XXX
"""


def test_the_real_minute_as_a_candump_log_gives_the_comma2k19_reader_s_labels(tmp_path):
    """The real RAV4 minute's CAN wheel speeds as the RAV4's own WHEEL_SPEEDS frames
    (opendbc's Toyota definition: Motorola byte order, an offset) at their logged times,
    and its u-blox fixes as frames of a GNSS message, in one candump log decoded by the two
    DBCs: the comma2k19 reader's 59 labelled seconds (measured: within 1.9e-6 m; the
    fixes rounded to 1e-7 deg, the wheel speeds exact in the DBC's counts)."""
    from rwhonet.data.streams import resample
    from support.canlog import FIX_ID
    from support.multirate import per_second
    from support.realminute import real_minute, reference_seconds

    minute = real_minute()
    ref = reference_seconds()
    tw, vw, tg, vg = minute.t_wheels, minute.wheels, minute.t_gnss, minute.gnss
    counts = np.round((vw * 3.6 + 67.67) / 0.01).astype(">u2")  # fl, fr, rl, rr
    wheels = np.ascontiguousarray(counts[:, [1, 0, 3, 2]]).view(np.uint8)  # FR FL RR RL
    fixes = np.ascontiguousarray(np.round(vg[:, :2] / 1e-7).astype("<i4")).view(np.uint8)
    stamps = np.r_[tw, tg]
    order = np.argsort(stamps, kind="stable")
    ids = np.r_[np.full(tw.size, 170), np.full(tg.size, FIX_ID)]
    path = write_bus_log(stamps[order], ids[order], np.r_[wheels, fixes][order], tmp_path / "a.log")
    (tmp_path / "toyota.dbc").write_text(TOYOTA_WHEELS)
    (tmp_path / "gnss.dbc").write_text(DBC)
    smap = {
        f"omega_{w}": ColumnSpec(f"WHEEL_SPEED_{w.upper()}", "km/h")
        for w in ("fl", "fr", "rl", "rr")
    } | {"lat": ColumnSpec("Lat", "deg"), "lon": ColumnSpec("Lon", "deg")}
    dbc = [str(tmp_path / "toyota.dbc"), str(tmp_path / "gnss.dbc")]
    streams = read_mdf4(path, smap, RAV4_RADIUS_M, NAME, "a.log", dbc)
    (wheel_stream,) = streams.wheels
    np.testing.assert_allclose(wheel_stream.t_s, tw, rtol=0, atol=1e-6)
    np.testing.assert_allclose(wheel_stream.channels[c.WHEELS[0]] * RAV4_RADIUS_M, vw[:, 0])
    got = per_second(resample(streams, nominal_radius_m=RAV4_RADIUS_M).drive.columns, RAV4_RADIUS_M)
    assert len(got) == len(ref) == 59
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=5e-6)


def test_a_refused_frame_is_named_by_its_message_and_line(tmp_path):
    """A wheel frame stamped far back (a clock set back): the refusal names the log, the
    message's identifier and the frame's line in the log, not its place in the message."""
    df = wavy_drive(10.0)
    log = write_bus_log(*can_frames(df, RADIUS_M, T0_S), tmp_path / "bus.log")
    lines = log.read_text().splitlines()
    at = next(i for i, x in enumerate(lines) if " 1A0#" in x and i > 20)
    lines[at] = "(1600000000.000000)" + lines[at].split(")", 1)[1]
    log.write_text("\n".join(lines) + "\n")
    (tmp_path / "bus.dbc").write_text(DBC)
    from rwhonet.data.streams import resample

    streams = read_mdf4(log, _signals(), RADIUS_M, NAME, "bus.log", [str(tmp_path / "bus.dbc")])
    with pytest.raises(InputError) as err:
        resample(streams, nominal_radius_m=RADIUS_M)
    said = str(err.value)
    assert f"bus.log [WheelSpeeds 0x1A0], row {at + 1}, column 'frame time stamp'" in said


@pytest.mark.parametrize("suffix", [".asc", ".blf", ".trc"])
def test_a_refused_frame_of_a_python_can_log_is_named_by_its_number(tmp_path, suffix):
    """As above for the logs python-can reads, which give no lines: the refusal names the
    frame's number among the log's frames (a TRC, read here since stop 80: its line)."""
    stamps, ids, data = can_frames(wavy_drive(10.0), RADIUS_M, T0_S)
    at = next(i for i, x in enumerate(ids) if x == 0x1A0 and i > 200)
    stamps = stamps.copy()
    stamps[at] -= (
        5.0  # a wheel frame stamped 5 s back (after the log's start, which ASC counts from)
    )
    log = write_bus_log(stamps, ids, data, tmp_path / f"bus{suffix}")
    (tmp_path / "bus.dbc").write_text(DBC)
    from rwhonet.data.streams import resample

    file = log.name
    streams = read_mdf4(log, _signals(), RADIUS_M, NAME, file, [str(tmp_path / "bus.dbc")])
    with pytest.raises(InputError) as err:
        resample(streams, nominal_radius_m=RADIUS_M)
    row = at + 1
    if suffix == ".trc":
        lines = log.read_text().splitlines()
        row = [i for i, x in enumerate(lines, 1) if not x.startswith(";")][at]
        assert row == at + 1 + 18  # python-can's writer's 18 header lines
    assert f"{file} [WheelSpeeds 0x1A0], row {row}, column 'frame time stamp'" in str(err.value)


def _real_minute_frames():
    """The real RAV4 minute as a logger beside its receiver has it: the WHEEL_SPEEDS frames'
    UTC stamps (its boot clock put on UTC by the receiver's own clock fit) and bytes
    (opendbc's Toyota layout: four big-endian counts of 0.01 km/h less 67.67, FR FL RR RL),
    its wheel speeds (m/s), and its u-blox fixes as GGA and RMC sentences."""
    from rwhonet.data.fixtimes import receiver_epochs
    from support.nmea import gga, rmc
    from support.realminute import real_minute

    minute = real_minute()
    tw, vw, tg, vg = minute.t_wheels, minute.wheels, minute.t_gnss, minute.gnss
    fit = receiver_epochs(tg, vg[:, 3])
    utc = tw + fit.offset_s + fit.drift * (tw - fit.t_ref_s)
    counts = np.round((vw * 3.6 + 67.67) / 0.01).astype(">u2")
    wheels = np.ascontiguousarray(counts[:, [1, 0, 3, 2]]).view(np.uint8)
    lines = []
    for i in range(tg.size):
        t = vg[i, 3] / 1000.0
        lines += [gga(t, vg[i, 0], vg[i, 1], 9), rmc(t, *vg[i, [0, 1, 2, 5]])]
    return utc, wheels, vw, lines


@pytest.mark.parametrize("log_name", ["can0.log", "can0.blf", "can0.trc"])
def test_the_real_minute_as_a_candump_log_beside_the_receiver_s_nmea_log(tmp_path, log_name):
    """A stream folder as a Linux logger writes it: the RAV4's WHEEL_SPEEDS frames in
    ``can0.log`` on the computer's UTC clock (the boot clock put on UTC by the receiver's
    own clock fit), the u-blox fixes as GGA and RMC sentences in ``gps.nmea`` without
    stamps. The map names the DBC's signals and a ``t`` no CSV has; the log's UTC times
    are placed by their RMC dates. The labels of the same wheel speeds in wheels.csv
    beside the same log (test_nmea.py's unstamped case: 59 seconds, 0.354 s later in the
    drive than the comma2k19 reader's), measured within 8.3e-8 m. The same frames in a
    Vector BLF (python-can's writer; read by rwhonet.data.blf, stop 78) and in a PEAK TRC
    (python-can's writer's 2.1; rwhonet.data.trc, stop 80) give them too."""
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample
    from support.multirate import per_second
    from support.nmea import write_nmea

    utc, wheels, vw, lines = _real_minute_frames()
    folders = {}
    for case in ("can", "csv"):
        folder = tmp_path / case
        write_nmea(folder / "gps.nmea", lines)
        folders[case] = folder
    log = write_bus_log(utc, np.full(utc.size, 170), wheels, folders["can"] / log_name)
    if not log_name.endswith(".log"):
        # a BLF keeps its start to the millisecond (the header's SYSTEMTIME), a TRC each
        # frame's offset to the microsecond: the CSV's wheels at the stamps python-can's
        # reader gives
        import can

        with can.LogReader(log) as reader:
            utc = np.array([m.timestamp for m in reader])
        assert np.abs(utc - _real_minute_frames()[0]).max() < 5e-4
    (tmp_path / "toyota.dbc").write_text(TOYOTA_WHEELS)
    columns = {"t": utc} | {w: vw[:, k] for k, w in enumerate(("fl", "fr", "rl", "rr"))}
    pd.DataFrame(columns).to_csv(folders["csv"] / "wheels.csv", index=False, float_format="%.6f")
    can_map = {"t": ColumnSpec("t", "s")} | {
        f"omega_{w}": ColumnSpec(f"WHEEL_SPEED_{w.upper()}", "km/h")
        for w in ("fl", "fr", "rl", "rr")
    }
    csv_map = {"t": ColumnSpec("t", "s")} | {
        f"omega_{w}": ColumnSpec(w, "m/s") for w in ("fl", "fr", "rl", "rr")
    }
    got, said = {}, {}
    for case, smap, dbc in (("can", can_map, [str(tmp_path / "toyota.dbc")]), ("csv", csv_map, [])):
        files = sorted(folders[case].iterdir())
        streams = read_stream_csvs(files, smap, RAV4_RADIUS_M, NAME, dbc=dbc)
        drive = resample(streams, nominal_radius_m=RAV4_RADIUS_M).drive.columns
        got[case], said[case] = per_second(drive, RAV4_RADIUS_M), " ".join(streams.notes)
    assert "RMC dates, on the stream files' UTC" in said["can"]
    assert f"{log_name}: raw CAN frames decoded with toyota.dbc: 1 of the log's 1" in said["can"]
    assert len(got["can"]) == len(got["csv"]) == 59
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got["can"][q], got["csv"][q], rtol=0, atol=1e-6)


def test_messages_on_two_buses_are_named_by_bus_and_a_mirrored_one_is_refused(tmp_path):
    """The wheels on can1 and the fix on can0: each stream named by its bus and message.
    The wheel message mirrored on can2 too (a gateway's copy): refused with the buses, and
    how to keep one."""
    df = wavy_drive(5.0)
    lines = write_bus_log(*can_frames(df, RADIUS_M, T0_S), tmp_path / "b.log").read_text()
    two = [x.replace(" can0 ", " can1 ") if " 1A0#" in x else x for x in lines.splitlines()]
    (tmp_path / "two.log").write_text("\n".join(two) + "\n")
    (tmp_path / "bus.dbc").write_text(DBC)
    dbc = [str(tmp_path / "bus.dbc")]
    streams = read_mdf4(tmp_path / "two.log", _signals(), RADIUS_M, NAME, "two.log", dbc)
    assert [s.name for s in streams.wheels] == ["can1 WheelSpeeds 0x1A0"]
    assert streams.gnss.name == "can0 GnssPos 0x600"
    mirrored = two + [x.replace(" can1 ", " can2 ") for x in two if " 1A0#" in x]
    (tmp_path / "mirror.log").write_text("\n".join(mirrored) + "\n")
    with pytest.raises(InputError) as err:
        read_mdf4(tmp_path / "mirror.log", _signals(), RADIUS_M, NAME, "mirror.log", dbc)
    problem = err.value.problems[0]
    assert problem.found == "2 signals of that name, on the buses can1, can2"
    assert (
        "grep ' can1 '" in problem.fix
        and f"{NAME.removesuffix('.signals')}.dbc per bus" in problem.fix
    )
    # the map's databases per bus: can2's copy is not decoded, the log reads as two.log
    per_bus = [(dbc[0], "can0"), (dbc[0], "can1")]
    got = read_mdf4(tmp_path / "mirror.log", _signals(), RADIUS_M, NAME, "mirror.log", per_bus)
    (wheels,) = got.wheels
    np.testing.assert_array_equal(wheels.t_s, streams.wheels[0].t_s)
    for w in c.WHEELS:
        np.testing.assert_array_equal(wheels.channels[w], streams.wheels[0].channels[w])
    assert "bus.dbc (can0), bus.dbc (can1)" in " ".join(got.notes)
    with pytest.raises(InputError) as err:  # a bus the log does not have
        read_mdf4(tmp_path / "mirror.log", _signals(), RADIUS_M, NAME, "m.log", [(dbc[0], "can 1")])
    (problem,) = err.value.problems
    assert problem.found == "the log's buses are can1, can0, can2"


def test_time_stamps_read_as_float_reads_them(tmp_path):
    """candump's fixed ``%010u.%06u`` stamps are read as one integer each and divided:
    the bits ``float()`` gives, also past 2**53 microseconds (read one by one) and where
    the stamps' widths differ."""
    rng = np.random.default_rng(7)
    for stamps in (
        [f"{x:.6f}" for x in 1.7e9 + rng.uniform(0, 86400, 500)],
        [f"{x:.6f}" for x in 9.0e9 + rng.uniform(0, 1e9, 50)],  # beyond 2**53 us
        ["1.5", "12.25", "100.125"],
    ):
        path = tmp_path / "t.log"
        path.write_text("".join(f"({s}) can0 0AA#01\n" for s in stamps))
        got = read_frames(path, "t.log").t_s
        assert got.tolist() == [float(s) for s in stamps]


def test_a_refused_can_log_in_a_stream_folder_is_said_once_naming_it(tmp_path):
    """can0.log holds no data frame: the folder is refused by that problem, naming the log,
    and not again by each wheel key "in none of the files" (a problem naming no file)."""
    from rwhonet.data.streamcsv import read_stream_csvs
    from support.nmea import gga, rmc, write_nmea

    (tmp_path / "can0.log").write_text("(1700000000.0) can0 20000080#0000000000000000\n")
    t0 = 1_700_000_000.0
    write_nmea(tmp_path / "gps.nmea", [gga(t0, 52.4, -1.5, 9), rmc(t0, 52.4, -1.5, 1.0, 0.0)])
    (tmp_path / "bus.dbc").write_text(DBC)
    smap = {"t": ColumnSpec("t", "s")} | {k: v for k, v in _signals().items() if "omega" in k}
    files = [tmp_path / "can0.log", tmp_path / "gps.nmea"]
    shown = {p: p.name for p in files}
    with pytest.raises(InputError) as err:
        read_stream_csvs(files, smap, RADIUS_M, NAME, shown, [str(tmp_path / "bus.dbc")])
    assert [p.file for p in err.value.problems] == ["can0.log"]
    assert err.value.problems[0].expected.startswith("CAN data frames")


@pytest.mark.parametrize("zone", ["Europe/Berlin", "America/Detroit", "Asia/Kolkata"])
def test_an_asc_log_s_date_line_in_the_map_s_zone_puts_its_frames_on_utc(
    tmp_path, monkeypatch, zone
):
    """CANalyzer on a computer keeping local time: its ASC counts seconds from the
    measurement's start, whose date line is that computer's wall clock. With the map's
    local_zone the frames are read on UTC at the stamps they were logged at (within the
    µs the ASC writes), whatever zone the reading machine keeps (here Asia/Tokyo); the
    notes say the date line and the zone. Without it, as before: from the start."""
    import time

    from support.canlog import write_asc_in_zone

    df = wavy_drive(30.0)
    stamps, ids, data = can_frames(df, RADIUS_M, T0_S)
    log = tmp_path / "bus.asc"
    start = write_asc_in_zone(stamps, ids, data, log, zone)
    monkeypatch.setenv("TZ", "Asia/Tokyo")
    time.tzset()
    try:
        frames = read_frames(log, "bus.asc", zone)
    finally:
        monkeypatch.undo()
        time.tzset()
    np.testing.assert_allclose(frames.t_s, np.r_[start, stamps], rtol=0, atol=2e-6)
    assert frames.clock.startswith("the ASC log's frame time stamps, s since the measurement")
    assert f" in {zone}): Unix time, s" in frames.clock and not frames.local_start
    plain = read_frames(log, "bus.asc")
    np.testing.assert_allclose(plain.t_s, np.r_[start, stamps] - start, rtol=0, atol=2e-6)
    assert plain.local_start  # from a start on the laptop's clock: no UTC stream shares it


def test_an_asc_log_without_a_date_line_is_refused_where_the_map_gives_a_zone(tmp_path):
    from support.canlog import write_asc_in_zone

    df = wavy_drive(10.0)
    stamps, ids, data = can_frames(df, RADIUS_M, T0_S)
    log = tmp_path / "bus.asc"
    write_asc_in_zone(stamps, ids, data, log, "UTC")
    lines = log.read_text().splitlines(keepends=True)
    log.write_text("".join(lines[1:]))  # the date line dropped
    with pytest.raises(InputError) as err:
        read_frames(log, "bus.asc", "UTC")
    (p,) = err.value.problems
    assert p.file == "bus.asc" and p.row is None and p.found == "none"
    assert p.expected.startswith("a date line before the first frame")
    assert "leave local_zone out of the map" in p.fix
    log.write_text("date Fri Dec 37 10:15:30.123 am 2026\n" + "".join(lines[1:]))
    with pytest.raises(InputError) as err:
        read_frames(log, "bus.asc", "UTC")
    (p,) = err.value.problems
    assert p.row == 1 and "which python-can cannot read" in p.found
    assert read_frames(log, "bus.asc").t_s.size == len(ids) + 1  # no zone: no date needed


def _real_minute_in_zone(tmp_path, name: str, zone: str, atol_m: float):  # type: ignore[no-untyped-def]
    """The RAV4's WHEEL_SPEEDS frames as a laptop in ``zone`` logs them (``name``:
    ``can.asc``, CANalyzer's ASC, or ``can.trc``, PCAN-View's TRC) and in a candump log on
    UTC, each beside its u-blox fixes as an unstamped NMEA log on UTC. Read with the map's
    local_zone, the laptop's 59 seconds are the candump folder's (within ``atol_m``);
    returns the laptop folder's notes, its refusal without local_zone, and its files."""
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample
    from support.canlog import write_asc_in_zone, write_trc_in_zone
    from support.multirate import per_second
    from support.nmea import write_nmea

    utc, wheels, _, lines = _real_minute_frames()
    folders = {case: tmp_path / case for case in ("candump", "laptop")}
    for folder in folders.values():
        write_nmea(folder / "gps.nmea", lines)
    write_bus_log(utc, np.full(utc.size, 170), wheels, folders["candump"] / "can0.log")
    write = write_asc_in_zone if name.endswith(".asc") else write_trc_in_zone
    write(utc, np.full(utc.size, 170), wheels, folders["laptop"] / name, zone)
    (tmp_path / "toyota.dbc").write_text(TOYOTA_WHEELS)
    smap = {"t": ColumnSpec("t", "s")} | {
        f"omega_{w}": ColumnSpec(f"WHEEL_SPEED_{w.upper()}", "km/h")
        for w in ("fl", "fr", "rl", "rr")
    }
    dbc = [str(tmp_path / "toyota.dbc")]
    got, notes = {}, {}
    for case, local_zone in (("candump", None), ("laptop", zone)):
        files = sorted(folders[case].iterdir())
        streams = read_stream_csvs(files, smap, RAV4_RADIUS_M, NAME, dbc=dbc, local_zone=local_zone)
        notes[case] = " ".join(streams.notes)
        got[case] = per_second(
            resample(streams, nominal_radius_m=RAV4_RADIUS_M).drive.columns, RAV4_RADIUS_M
        )
    assert len(got["laptop"]) == len(got["candump"]) == 59
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got["laptop"][q], got["candump"][q], rtol=0, atol=atol_m)
    files = sorted(folders["laptop"].iterdir())
    with pytest.raises(InputError) as err:
        read_stream_csvs(files, smap, RAV4_RADIUS_M, NAME, dbc=dbc)
    return notes["laptop"], str(err.value), files


def test_the_real_minute_as_an_asc_log_in_local_time_beside_the_receiver_s_nmea_log(tmp_path):
    """The RAV4's WHEEL_SPEEDS frames as CANalyzer on a computer in Detroit would log them
    (an ASC counting from its measurement's start, its date line in local time), beside
    its u-blox fixes as an unstamped NMEA log on UTC: with the map's local_zone the same
    labels as the frames in a candump log on UTC (within 1e-6 m); without it, refused
    naming the log counting from its start and the local_zone to give."""
    _, said, _ = _real_minute_in_zone(tmp_path, "can.asc", "America/Detroit", 1e-6)
    assert "gps.nmea" in said and "local_zone" in said


def test_the_real_minute_as_a_pcan_view_trc_in_local_time_beside_the_receiver_s_nmea_log(
    tmp_path,
):
    """The RAV4's WHEEL_SPEEDS frames as PCAN-View on a computer in Berlin would log them (a
    TRC whose $STARTTIME is the start on the computer's local clock, ten decimals of a day),
    beside its u-blox fixes as an unstamped NMEA log on UTC: with the map's local_zone the
    labels of the frames in a candump log on UTC (within 1e-5 m: the start to 4 µs; August:
    CEST, UTC+2 h); without it, refused naming the TRC's local clock and the local_zone to
    give. A TRC without $STARTTIME (1.0) is refused where the map gives a zone."""
    notes, said, files = _real_minute_in_zone(tmp_path, "can.trc", "Europe/Berlin", 1e-5)
    assert "in Europe/Berlin, UTC+2 h) plus each frame's offset" in notes
    assert "gps.nmea" in said and "can.trc keeps the logging computer's local clock" in said
    assert "a TRC's $STARTTIME" in said
    log = next(f for f in files if f.suffix == ".trc")
    log.write_text(";   Start time: 02.08.2018 18:14:47.000\n     1)      1841  00AA  1  0C\n")
    with pytest.raises(InputError) as err:
        read_frames(log, log.name, local_zone="Europe/Berlin")
    assert "column '$STARTTIME'" in str(err.value) and "none (a TRC 1.0 log" in str(err.value)


@pytest.mark.parametrize("zone", [None, "Europe/Berlin"])
def test_an_asc_log_of_relative_stamps_is_read_on_the_measurement_s_clock(tmp_path, zone):
    """CANoe's logging block set to relative time: each event's stamp is the time since
    the event before it (Vector's ASC format), the header says ``timestamps relative``.
    Its frames are read at the stamps an absolute log of the same events gives (every
    stamped event counting: the start of measurement, an error frame, a bus statistic
    python-can passes over), with the map's local_zone too, and the clock says so."""
    from support.canlog import asc_as_relative, write_asc_in_zone

    df = wavy_drive(10.0)
    stamps, ids, data = can_frames(df, RADIUS_M, T0_S)
    absolute = tmp_path / "abs" / "bus.asc"
    write_asc_in_zone(stamps, ids, data, absolute, "Europe/Berlin")
    lines = absolute.read_text().splitlines(keepends=True)
    at = next(i for i, x in enumerate(lines) if x.startswith(" 1.3"))  # after 1.2xx s
    lines[at:at] = [
        " 1.250000 1  ErrorFrame\n",
        " 1.250500 2  Statistic: D 0 R 0 XD 0 XR 0 E 0 O 0 B 0.00%\n",
        "// a comment, no event\n",
    ]
    absolute.write_text("".join(lines))
    relative = tmp_path / "bus.asc"
    relative.write_text(asc_as_relative(absolute.read_text()))
    assert "timestamps relative" in relative.read_text()
    want, got = read_frames(absolute, "bus.asc", zone), read_frames(relative, "bus.asc", zone)
    assert got.t_s.size == want.t_s.size == len(ids) + 1
    np.testing.assert_allclose(got.t_s, want.t_s, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(got.rows, want.rows)
    np.testing.assert_array_equal(got.data, want.data)
    assert got.passed == want.passed == "1 error frames"
    assert got.local_start == (zone is None)
    assert "each event's time since the one before, summed" in (
        got.clock if zone is None else read_frames(relative, "bus.asc").clock
    )


# A whole bus's log: the drive's messages among the rest of the bus's traffic (a message
# the DBC defines that the map does not name, identifiers the DBC does not define, extended
# identifiers), as a logger on a car's bus records it.
OTHER_DBC = DBC + '\nBO_ 800 Other: 8 ESC\n SG_ Junk : 0|16@1+ (1,0) [0|65535] "" Vector__XXX\n'


def _whole_bus(df, seed: int = 3):  # type: ignore[no-untyped-def]
    stamps, ids, data = can_frames(df, RADIUS_M, T0_S)
    rng = np.random.default_rng(seed)
    n = 4 * len(stamps)
    other_t = rng.uniform(stamps[0], stamps[-1], n)
    other_ids = rng.choice([800, 0x123, 0x7FF, 0x18FEF100, 0x1A1], n)
    other = rng.integers(0, 256, (n, 8), dtype=np.uint8)
    order = np.argsort(np.r_[stamps, other_t], kind="stable")
    return (
        np.r_[stamps, other_t][order],
        np.r_[ids, other_ids][order],
        np.concatenate([data, other])[order],
        np.r_[np.zeros(len(ids), bool), other_ids > 0x7FF][order],
    )


def _kept_and_whole(log, dbc, monkeypatch):  # type: ignore[no-untyped-def]
    """The log's streams through the map, read keeping the map's messages and read whole
    (asserted the same: names, times, values, rows)."""
    from rwhonet.data import mdf4

    kept = read_mdf4(log, _signals(), RADIUS_M, NAME, log.name, dbc)
    with monkeypatch.context() as m:
        m.setattr(mdf4, "_wanted", lambda *a: None)
        whole = read_mdf4(log, _signals(), RADIUS_M, NAME, log.name, dbc)
    for a, b in [*zip(kept.wheels, whole.wheels, strict=True), (kept.gnss, whole.gnss)]:
        assert a.name == b.name
        np.testing.assert_array_equal(a.t_s, b.t_s)
        for k in b.channels:
            np.testing.assert_array_equal(a.channels[k], b.channels[k])
        np.testing.assert_array_equal(a.rows, b.rows)
    return kept, whole


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf", ".trc"])
def test_a_whole_bus_log_is_decoded_from_the_map_s_messages_alone(tmp_path, suffix, monkeypatch):
    """Read keeping only the frames of the messages the map's signals are in, a whole bus's
    log gives the streams (times, values, rows), notes and frame-ID count it gave read
    whole, the frames left out counted; ``read_frames`` with the filter gives exactly the
    frames read whole that the filter keeps, and every frame's ID in ``log_ids``."""
    from rwhonet.data.canlog import _taken
    from rwhonet.data.keptframes import FrameFilter, frame_keys

    stamps, ids, data, ext = _whole_bus(wavy_drive(20.0))
    log = write_bus_log(stamps, ids, data, tmp_path / f"bus{suffix}", extended=ext)
    (tmp_path / "bus.dbc").write_text(OTHER_DBC)
    dbc = [str(tmp_path / "bus.dbc")]
    kept, whole = _kept_and_whole(log, dbc, monkeypatch)
    note = (
        f"{log.name}: {len(ids) - 4 * len(ids) // 5} of them decoded, those of the 3 "
        "message(s) the map's signals are in; the other frames were counted and left out as "
        "the log was read"
    )
    assert [n for n in kept.notes if n != note] == list(whole.notes)
    said = " ".join(kept.notes)
    assert "bus.dbc: 4 of the log's 8 frame IDs defined" in said
    assert f"{len(ids)} data frames on 1 bus(es)" in said
    keep = FrameFilter(frozenset({(0x1A0, False), (0x600, False), (800, False)}))
    every, some = read_frames(log, log.name), read_frames(log, log.name, keep=keep)
    at = np.flatnonzero(keep.mask(every.ids, every.extended))
    assert_same_frames(some, _taken(every, at))
    assert some.dropped == every.t_s.size - at.size and some.in_log == every.in_log
    np.testing.assert_array_equal(
        some.log_ids, np.unique(frame_keys(every.channel, every.ids, every.extended))
    )


def test_a_candump_log_read_in_parts_gives_the_frames_read_whole(tmp_path, monkeypatch):
    """Parts of 1 kB (about 25 lines each): an interface first seen in a later part and one
    seen in an earlier part first numbered by the log's order, damaged lines, lines that
    are no frame and comments counted with the log's first, an FD frame in a late part,
    the last line without its line end; with a filter, the same frames kept and IDs seen."""
    from rwhonet.data import canlog
    from rwhonet.data.keptframes import FrameFilter

    stamps, ids, data, ext = _whole_bus(wavy_drive(20.0))
    lines = write_bus_log(stamps, ids, data, tmp_path / "b.log", extended=ext).read_text()
    lines = lines.splitlines()
    lines[300] = lines[300].replace(" can0 ", " vcan1 ")
    lines[100] = lines[100].replace(" can0 ", " can1 ")
    lines[700] = lines[700].replace(" can0 ", " can1 ")
    lines[120] = "garbage"
    lines[400] = lines[400].removesuffix(" R")[:-1]  # a digit lost: damaged
    lines[500] = "# a comment"
    lines[650] = "(1700000010.000000) can0 0AA##1" + "AB" * 12
    lines[800] = "more garbage"
    lines[900] = lines[900].replace("#", "#Z")
    (tmp_path / "bus.log").write_text("\n".join(lines))
    path = tmp_path / "bus.log"
    monkeypatch.setattr(canlog, "_CANDUMP_PART_BYTES", 1 << 30)
    whole = read_frames(path, "bus.log")
    keep = FrameFilter(frozenset({(0x1A0, False), (0x18FEF100, True)}))
    whole_kept = read_frames(path, "bus.log", keep=keep)
    monkeypatch.setattr(canlog, "_CANDUMP_PART_BYTES", 1 << 10)
    parts = read_frames(path, "bus.log")
    assert_same_frames(parts, whole)
    assert whole.buses == ["can0", "can1", "vcan1"] and whole.data.shape[1] == 64
    assert "2 lines damaged (first at line 401)" in whole.passed
    assert "2 lines that are no frame (first at line 121)" in whole.passed
    assert parts.rows[-1] == len(lines)
    parts_kept = read_frames(path, "bus.log", keep=keep)
    assert_same_frames(parts_kept, whole_kept)
    np.testing.assert_array_equal(parts_kept.log_ids, whole_kept.log_ids)
    assert parts_kept.dropped == whole_kept.dropped > 0


@pytest.mark.parametrize("suffix", [".log", ".blf"])
def test_a_truck_s_j1939_bus_is_decoded_from_the_map_s_parameter_groups_alone(
    tmp_path, suffix, monkeypatch
):
    """A J1939 database's messages are matched by parameter group and the frame's source
    address, not identifier: read keeping only the frames of the map's groups, a truck's
    whole bus (its ECUs' own priorities and addresses, other groups, a group on data page
    1, standard identifiers that asammdf takes for group 0's TSC1) gives the streams, rows,
    notes and count of frame IDs decoded it gave read whole, and the filter keeps every
    frame read whole of the map's groups; a second ECU sending a map's group is refused
    as read whole (two signals of the name)."""
    from rwhonet.data import mdf4
    from rwhonet.data.canlog import _taken
    from rwhonet.data.keptframes import FrameFilter

    stamps, ids, data, _ = _whole_bus(wavy_drive(20.0))
    sent = np.array([J1939_SENT.get(int(i), int(i)) for i in ids], np.int64)
    other = np.flatnonzero(sent == 0x18FEF100)
    sent[other[::2]] = 0x19FEBF0B  # EBC2's group on data page 1: another group
    sent[other[1::4]] = 0x18000023  # TSC1 from 0x23, as 0x123 reads: one found, two IDs
    ext = sent > 0x7FF
    log = write_bus_log(stamps, sent, data, tmp_path / f"bus{suffix}", extended=ext)
    (tmp_path / "truck.dbc").write_text(J1939_DBC)
    dbc = [str(tmp_path / "truck.dbc")]
    signals = _signals()
    kept, whole = _kept_and_whole(log, dbc, monkeypatch)
    extra = [n for n in kept.notes if n not in whole.notes]
    assert len(extra) == 1 and "message(s) the map's signals are in" in extra[0]
    assert [n for n in kept.notes if n not in extra] == list(whole.notes)
    said = " ".join(whole.notes)
    assert "truck.dbc: 7 of the log's 10 frame IDs defined" in said  # TSC1 from 4 addresses
    keep = FrameFilter(frozenset(), frozenset({0xFEBF, 0xEF00, 0xFF21}))
    every, some = read_frames(log, log.name), read_frames(log, log.name, keep=keep)
    at = np.flatnonzero(keep.mask(every.ids, every.extended))
    assert at.size == len(ids) - 4 * len(ids) // 5
    assert_same_frames(some, _taken(every, at))
    # a second ECU sending the fix's group: two of its signals, refused alike
    sent[other[1::2]] = 0x18EF0B2A
    log = write_bus_log(stamps, sent, data, tmp_path / f"two{suffix}", extended=ext)
    with pytest.raises(InputError) as kept_error:
        read_mdf4(log, signals, RADIUS_M, NAME, log.name, dbc)
    with monkeypatch.context() as m, pytest.raises(InputError) as whole_error:
        m.setattr(mdf4, "_wanted", lambda *a: None)
        read_mdf4(log, signals, RADIUS_M, NAME, log.name, dbc)
    assert str(kept_error.value) == str(whole_error.value)
    said = "found 2 signals of that name, in the messages GnssPos 0x18EF0B1C, GnssPos 0x18EF0B2A"
    assert said in str(kept_error.value)


def test_the_map_s_messages_are_kept_by_the_names_of_their_signals(tmp_path):
    """A signal named alone, by its message or by its bus and message keeps its message;
    the log is read whole where a column is no signal of the databases (unless the log is
    one of a stream folder's files, whose other files give it), where a database is not
    there, or where it is J1939's (matched by parameter group, not identifier)."""
    from rwhonet.data.mdf4 import _wanted

    (tmp_path / "bus.dbc").write_text(OTHER_DBC)
    dbc = [str(tmp_path / "bus.dbc")]
    got = _wanted(dbc, ["WhlSpd_FL", "WheelSpeeds.WhlSpd_RR", "CAN2.GnssPos.Lat"], False)
    assert got is not None and got.keep.messages == {(0x1A0, False), (0x600, False)}
    assert _wanted(dbc, ["WhlSpd_FL", "gps_lat"], False) is None
    got = _wanted(dbc, ["WhlSpd_FL", "gps_lat"], True)
    assert got is not None and got.keep.messages == {(0x1A0, False)}
    assert _wanted(dbc, ["gps_lat"], True) is None
    assert _wanted([str(tmp_path / "none.dbc")], ["WhlSpd_FL"], False) is None
    # marked J1939 with standard identifiers: asammdf drops the flag, so by identifier
    (tmp_path / "j1939.dbc").write_text(OTHER_DBC.replace("BU_:", J1939_FLAG + "BU_:"))
    got = _wanted([str(tmp_path / "j1939.dbc")], ["WhlSpd_FL"], False)
    assert got is not None and got.keep == FrameFilter(frozenset({(0x1A0, False)}))
    # a truck's: by parameter group (a PDU2 group's extension in it, a PDU1's address not)
    (tmp_path / "truck.dbc").write_text(J1939_DBC)
    got = _wanted([str(tmp_path / "truck.dbc")], ["WhlSpd_FL", "Lat", "Sats"], False)
    assert got is not None and got.keep == FrameFilter(
        frozenset(), frozenset({0xFEBF, 0xEF00, 0xFF21})
    )
    assert got.messages == 3


def test_a_map_s_message_missing_from_the_log_is_said_as_for_a_log_read_whole(tmp_path):
    """The map names the yaw rate, which the DBC defines and the log has no frame of: the
    log is read again whole, and refused as before, naming the signals it has."""
    df = wavy_drive(5.0)
    log = write_bus_log(*_whole_bus(df)[:3], tmp_path / "bus.log")
    (tmp_path / "bus.dbc").write_text(
        OTHER_DBC
        + '\nBO_ 900 Yaw: 8 ESC\n SG_ YawRate : 0|16@1- (0.01,0) [-300|300] "deg/s" Vector__XXX\n'
    )
    signals = {**_signals(), "yaw_rate": ColumnSpec(column="YawRate", unit="deg/s")}
    with pytest.raises(InputError) as err:
        read_mdf4(log, signals, RADIUS_M, NAME, "bus.log", [str(tmp_path / "bus.dbc")])
    (problem,) = err.value.problems
    assert problem.column == "YawRate" and "no such signal; the file has" in problem.found
    assert "Junk" in problem.found  # the log's other message, decoded as before


def _on_buses(path, stamps, ids, data, ext, channels):  # type: ignore[no-untyped-def]
    """Frames written by python-can's writer for ``path``'s suffix, each on its bus; every
    97th a remote frame, every 89th an error frame (not in TRC: python-can's writer writes
    neither)."""
    import can

    with can.Logger(str(path)) as writer:
        for n, (t, i, d, x, ch) in enumerate(
            zip(stamps.tolist(), ids.tolist(), data, ext.tolist(), channels.tolist(), strict=True)
        ):
            other = path.suffix != ".trc"
            remote, error = other and n % 97 == 96, other and n % 89 == 88
            writer.on_message_received(
                can.Message(
                    timestamp=t,
                    arbitration_id=i,
                    is_extended_id=x,
                    data=None if remote else bytes(d),
                    dlc=8,
                    is_remote_frame=remote,
                    is_error_frame=error,
                    channel=ch,
                )
            )
    return path


def _on_three_buses(path):  # type: ignore[no-untyped-def]
    """A whole bus's log on three buses: its first frame on bus 1, most on bus 0, some on
    bus 2 from the 152nd and on bus 1 from the 402nd (python-can's channel numbers)."""
    stamps, ids, data, ext = _whole_bus(wavy_drive(20.0))
    n = np.arange(len(ids))
    channels = np.where((n > 150) & (n % 7 == 3), 2, np.where((n > 400) & (n % 5 == 1), 1, 0))
    channels[0] = 1
    return _on_buses(path, stamps, ids, data, ext, channels)


def _assert_kept_as_read_whole(log, whole) -> FrameFilter:  # type: ignore[no-untyped-def]
    """That the log read with a filter gives the frames of ``whole`` (it read whole) the
    filter keeps, the others counted, every frame's bus and ID in ``log_ids``."""
    from rwhonet.data.canlog import _taken
    from rwhonet.data.keptframes import frame_keys

    keep = FrameFilter(frozenset({(0x1A0, False), (0x18FEF100, True), (0x123, False)}))
    some = read_frames(log, log.name, keep=keep)
    at = np.flatnonzero(keep.mask(whole.ids, whole.extended))
    assert_same_frames(some, _taken(whole, at))
    assert some.dropped == whole.t_s.size - at.size > 0
    np.testing.assert_array_equal(
        some.log_ids, np.unique(frame_keys(whole.channel, whole.ids, whole.extended))
    )
    return keep


@pytest.mark.parametrize("suffix", [".trc", ".asc", ".blf"])
def test_a_log_on_three_buses_read_a_part_at_a_time_keeps_the_frames_it_would_read_whole(
    tmp_path, monkeypatch, suffix
):
    """Parts of 2 kB (BLF: of its objects inflated): the buses numbered in the order first
    seen among every frame (bus 2 first, then bus 1 in the same part, bus 3 first in a
    later part), the frames kept those of the log read whole that the filter keeps, every
    frame's bus and ID in ``log_ids``."""
    from rwhonet.data import asc, blf, trc

    log = _on_three_buses(tmp_path / f"bus{suffix}")
    every = read_frames(log, log.name)
    # TRC numbers python-can's channel 0 as bus 1; ASC and BLF read back python-can's own
    assert every.buses == (["2", "1", "3"] if suffix == ".trc" else ["1", "0", "2"])
    if suffix != ".trc":
        assert "error frames" in every.passed and "remote frames" in every.passed
    for module in (trc, asc):
        monkeypatch.setattr(module, "CHUNK_BYTES", 2048)
    monkeypatch.setattr(blf, "BATCH_BYTES", 2048)
    _assert_kept_as_read_whole(log, every)


def test_an_asc_python_can_reads_is_kept_a_batch_at_a_time_as_read_whole(tmp_path, monkeypatch):
    """An ASC the fast reader leaves to python-can (a form feed in a comment line: a stray
    control byte) is read by it a batch of messages at a time: batches of 50 give the
    frames one batch gives (the fast reader's, of the log without the byte), buses
    numbered in the order first seen among every frame; with a filter, the frames read
    whole that it keeps, the others counted, every frame's bus and ID in ``log_ids``."""
    from rwhonet.data import canlog
    from rwhonet.data.canlog import _asc

    plain = _on_three_buses(tmp_path / "plain.asc")
    text = plain.read_text()
    log = tmp_path / "bus.asc"
    log.write_text(text.replace("End TriggerBlock", "// a page break \x0c\nEnd TriggerBlock"))
    assert _asc(log, log.name) is None  # python-can's to read
    monkeypatch.setattr(canlog, "PYTHON_CAN_BATCH", 1 << 30)
    whole = read_frames(log, log.name)
    assert_same_frames(whole, read_frames(plain, log.name))
    assert whole.buses == ["1", "0", "2"]
    monkeypatch.setattr(canlog, "PYTHON_CAN_BATCH", 50)
    assert_same_frames(read_frames(log, log.name), whole)
    keep = _assert_kept_as_read_whole(log, whole)
    # a byte python-can cannot read after 120 data frames: its error, and those counted
    lines = log.read_text().splitlines(keepends=True)
    events = [i for i, x in enumerate(lines) if " Rx   d " in x]
    lines.insert(events[120], " 9.000000 1  1A0             Rx   d 2 zz 1f\n")
    log.write_text("".join(lines))
    with pytest.raises(InputError, match=r"it failed after 120 frame\(s\)"):
        read_frames(log, log.name, keep=keep)


def test_two_whole_bus_logs_of_a_stream_folder_each_keep_the_map_s_messages_they_have(
    tmp_path, monkeypatch
):
    """A folder of two candump logs, one a bus each (the wheels on one, the fix and its
    satellites on the other, each among its bus's other traffic): each keeps the map's
    messages it has, not read whole for the ones the other has, and the folder gives the
    streams it gives read whole."""
    from rwhonet.data import mdf4
    from rwhonet.data.streamcsv import read_stream_csvs

    stamps, ids, data, ext = _whole_bus(wavy_drive(20.0))
    wheels = np.isin(ids, (0x1A0, 0x123, 0x7FF))
    write_bus_log(stamps[wheels], ids[wheels], data[wheels], tmp_path / "can0.log")
    write_bus_log(
        stamps[~wheels], ids[~wheels], data[~wheels], tmp_path / "can1.log", "can1", ext[~wheels]
    )
    (tmp_path / "bus.dbc").write_text(OTHER_DBC)
    smap = {"t": ColumnSpec("t", "s")} | _signals()
    files = [tmp_path / "can0.log", tmp_path / "can1.log"]
    args = (smap, RADIUS_M, NAME, {p: p.name for p in files}, [str(tmp_path / "bus.dbc")])
    kept = read_stream_csvs(files, *args)
    with monkeypatch.context() as m:
        m.setattr(mdf4, "_wanted", lambda *a: None)
        whole = read_stream_csvs(files, *args)
    for a, b in [*zip(kept.wheels, whole.wheels, strict=True), (kept.gnss, whole.gnss)]:
        np.testing.assert_array_equal(a.t_s, b.t_s)
        for k in b.channels:
            np.testing.assert_array_equal(a.channels[k], b.channels[k])
    said = " ".join(kept.notes)
    for log in ("can0.log", "can1.log"):
        assert f"{log}: " in said and "those of the 3 message(s) the map's signals are in" in said
    assert said.count("those of the 3 message(s)") == 2


def test_a_can_database_is_loaded_once_a_process_until_its_file_changes(tmp_path):
    """The messages' filter and the decode share one load of a DBC (a car's of 2,000
    messages takes 0.1-0.2 s), kept while its file is unchanged; written again, it is
    loaded again."""
    import os

    from rwhonet.data.mdf4 import _database

    path = tmp_path / "bus.dbc"
    path.write_text(DBC)
    first = _database(path)
    assert first is not None and _database(path) is first
    path.write_text(OTHER_DBC)
    os.utime(path, ns=(1, 1))
    again = _database(path)
    assert again is not first and len(again.frames) == len(first.frames) + 1
    assert _database(tmp_path / "none.dbc") is None


def _bus_drive(tmp_path, seconds: float = 60.0, other: int = 20):  # type: ignore[no-untyped-def]
    """A whole bus's candump log of a ``seconds`` drive (``other`` frames of the rest of
    the bus to each of the drive's) in ``tmp_path/raw``, with its DBC."""
    stamps, ids, data = can_frames(wavy_drive(seconds), RADIUS_M, T0_S)
    rng = np.random.default_rng(0)
    n = other * len(stamps)
    t = np.r_[stamps, rng.uniform(stamps[0], stamps[-1], n)]
    order = np.argsort(t, kind="stable")
    log = write_bus_log(
        t[order],
        np.r_[ids, rng.choice(np.arange(0x100, 0x180), n)][order],
        np.concatenate([data, rng.integers(0, 256, (n, 8), dtype=np.uint8)])[order],
        tmp_path / "raw" / "bus.log",
    )
    (tmp_path / "raw" / "bus.dbc").write_text(DBC)
    return log, len(ids)


def _read_drive(path, max_mb: float, fmt: str = "bus", reader: str = "mdf4"):  # type: ignore[no-untyped-def]
    from rwhonet.data.drivefile import DriveFile, read_any
    from support.drives import make_params

    root = path.parent if path.is_file() else path
    dbc = str(root / "bus.dbc") if (root / "bus.dbc").exists() else str(root.parent / "bus.dbc")
    signals = SIGNALS if reader == "mdf4" else {"t": {"column": "t", "unit": "s"}, **SIGNALS}
    maps = {fmt: {"reader": reader, "signals": signals, "dbc": dbc}} if fmt != "iovnbd" else {}
    data = make_params(root, **{"data.signal_maps": maps, "data.max_file_mb": max_mb}).data
    f = DriveFile("bus", "target_test", "target", fmt, path)
    return read_any(f, data, lambda p: p.name, RADIUS_M, 0.1, 10.0)[0]


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf", ".trc"])
def test_a_log_keeps_at_most_the_bound_s_frames_naming_the_row_past_it(tmp_path, suffix):
    """A filter's ``max_frames``: the frames kept up to it are those kept without it; one
    more is refused, naming the log and the frame one too many by its row (a candump or
    TRC log's line, an ASC or BLF log's number among its messages), as a decode names a
    frame."""
    stamps, ids, data, ext = _whole_bus(wavy_drive(20.0))
    log = write_bus_log(stamps, ids, data, tmp_path / f"bus{suffix}", extended=ext)
    keep = FrameFilter(frozenset({(0x1A0, False), (0x600, False)}))
    every = read_frames(log, log.name, keep=keep)
    n = every.t_s.size
    assert_same_frames(
        read_frames(log, log.name, keep=dataclasses.replace(keep, max_frames=n)), every
    )
    for limit in (n - 1, n // 3):
        with pytest.raises(InputError) as err:
            read_frames(log, log.name, keep=dataclasses.replace(keep, max_frames=limit))
        (problem,) = err.value.problems
        assert (problem.file, problem.row) == (log.name, every.rows[limit])
        assert problem.expected == (
            f"at most {limit:,} frames of the messages the map's signals are in "
            "(data.max_file_mb at 256 bytes a frame kept)"
        )
        assert "split the log into several" in problem.fix


def test_a_candump_log_s_bound_is_kept_across_its_parts(tmp_path, monkeypatch):
    """Parts of 1 kB: the frame past the bound named by its line in whichever part, a
    damaged line before it (which is no frame, so lines and frames differ)."""
    from rwhonet.data import canlog

    stamps, ids, data, ext = _whole_bus(wavy_drive(20.0))
    path = write_bus_log(stamps, ids, data, tmp_path / "bus.log", extended=ext)
    lines = path.read_text().splitlines()
    lines[50] = "garbage"
    path.write_text("\n".join(lines) + "\n")
    keep = FrameFilter(frozenset({(0x1A0, False)}))
    every = read_frames(path, "bus.log", keep=keep)
    monkeypatch.setattr(canlog, "_CANDUMP_PART_BYTES", 1 << 10)
    with pytest.raises(InputError) as err:
        read_frames(path, "bus.log", keep=dataclasses.replace(keep, max_frames=150))
    assert err.value.problems[0].row == every.rows[150] > 150 * 5 // 2


def test_a_whole_bus_log_above_max_file_mb_is_read_its_kept_frames_bounded(tmp_path):
    """data.max_file_mb bounds a drive by its file's size, but a raw CAN log is read a part
    at a time: a whole bus's candump (alone, kept compressed, or in a stream folder beside
    the receiver's log) three times the limit is read, as with the limit raised; the same
    log's map's messages above the limit's frames (256 bytes each) are refused naming
    it. A CSV of the log's size is still refused."""
    import gzip
    import shutil

    log, kept = _bus_drive(tmp_path)
    size_mb = log.stat().st_size / 2**20
    limit_mb = size_mb / 3
    assert FrameFilter.frames_for(limit_mb) > kept > FrameFilter.frames_for(limit_mb / 2)
    wide = _read_drive(log, 10 * size_mb)
    got = _read_drive(log, limit_mb)
    for k in (c.T_S, *c.WHEELS, c.LAT_DEG):
        np.testing.assert_array_equal(got.columns[k], wide.columns[k])
    with pytest.raises(InputError) as err:
        _read_drive(log, limit_mb / 2)
    (problem,) = err.value.problems
    assert problem.file == "bus.log" and problem.row is not None
    assert f"at most {FrameFilter.frames_for(limit_mb / 2):,} frames" in problem.expected
    packed = tmp_path / "packed"
    packed.mkdir()
    shutil.copy(tmp_path / "raw" / "bus.dbc", packed / "bus.dbc")
    (packed / "bus.log.gz").write_bytes(gzip.compress(log.read_bytes()))
    got = _read_drive(packed / "bus.log.gz", limit_mb)
    np.testing.assert_array_equal(got.columns[c.T_S], wide.columns[c.T_S])
    (tmp_path / "raw" / "big.csv").write_bytes(b"t\n" + b"0\n" * int(size_mb * 2**19))
    with pytest.raises(InputError) as err:
        _read_drive(tmp_path / "raw" / "big.csv", limit_mb, "iovnbd")
    assert "a drive file of at most" in err.value.problems[0].expected


def test_a_compressed_can_log_s_copy_is_bounded_by_the_scratch_disk(tmp_path, monkeypatch):
    """A raw CAN log kept compressed is written to a scratch file (read from there a part
    at a time): a copy that would leave less than the reserve free is refused, naming it."""
    import gzip

    from rwhonet.data import compressed

    log, _ = _bus_drive(tmp_path, 10.0, 2)
    packed = log.with_name("bus.log.gz")
    packed.write_bytes(gzip.compress(log.read_bytes()))
    log.unlink()
    free_mb = shutil_free_mb(tmp_path)
    monkeypatch.setattr(compressed, "SCRATCH_RESERVE_MB", free_mb + 10**6)
    with pytest.raises(InputError) as err:
        _read_drive(packed, 512)
    (problem,) = err.value.problems
    assert problem.file == "bus.log.gz"
    assert problem.expected.startswith("a CAN log that fits the scratch disk once decompressed")
    assert "more than that in this gzip file" in problem.found and "TMPDIR" in problem.fix


def shutil_free_mb(path) -> int:  # type: ignore[no-untyped-def]
    import shutil

    return shutil.disk_usage(path).free // 2**20


def test_a_can_log_read_whole_is_bounded_by_its_size(tmp_path, monkeypatch):
    """Where the map's messages cannot be told apart (a signal no database defines) or
    one is missing from the log (read again whole, to say what it has), the log is read
    whole, every frame held: above data.max_file_mb it is refused first, saying why it
    would be read whole. A database that is not there is refused before the log is read."""
    from rwhonet.data import canlog

    log, _ = _bus_drive(tmp_path)
    size_mb = log.stat().st_size / 2**20
    limit_mb = size_mb / 3
    renamed = {**SIGNALS, "n_sats": {"column": "Satellites", "unit": "count"}}
    dbc = tmp_path / "raw" / "bus.dbc"
    signals = {k: ColumnSpec(**v) for k, v in renamed.items()}
    with pytest.raises(InputError) as err:
        read_mdf4(log, signals, RADIUS_M, NAME, "bus.log", [str(dbc)], max_mb=limit_mb)
    (problem,) = err.value.problems
    assert problem.expected == f"a CAN log read whole of at most {limit_mb:g} MB (data.max_file_mb)"
    assert problem.found == f"{size_mb:,.1f} MB, to be read whole as no database defines Satellites"
    with pytest.raises(InputError) as err:  # within the limit: read whole, said as before
        read_mdf4(log, signals, RADIUS_M, NAME, "bus.log", [str(dbc)], max_mb=3 * size_mb)
    assert "no such signal; the file has" in err.value.problems[0].found
    dbc.write_text(
        DBC
        + '\nBO_ 900 Yaw: 8 ESC\n SG_ YawRate : 0|16@1- (0.01,0) [-300|300] "deg/s" Vector__XXX\n'
    )
    signals = {**_signals(), "yaw_rate": ColumnSpec(column="YawRate", unit="deg/s")}
    with pytest.raises(InputError) as err:
        read_mdf4(log, signals, RADIUS_M, NAME, "bus.log", [str(dbc)], max_mb=limit_mb)
    assert err.value.problems[0].found.endswith("as the log has no frame of Yaw 0x384")
    with pytest.raises(InputError) as err:
        read_mdf4(log, signals, RADIUS_M, NAME, "bus.log", [str(dbc)], max_mb=3 * size_mb)
    assert "no such signal; the file has" in err.value.problems[0].found
    monkeypatch.setattr(canlog, "_read", lambda *a: pytest.fail("the log was read"))
    with pytest.raises(InputError) as err:
        read_mdf4(log, _signals(), RADIUS_M, NAME, "bus.log", [str(tmp_path / "none.dbc")])
    assert err.value.problems[0].found == "no such file"


def test_a_stream_folder_s_size_leaves_its_raw_can_logs_out():
    """Its CSVs and receiver logs are counted (read whole), its raw CAN logs, rotated or
    kept compressed, are not; a NovAtel receiver's .log is a receiver's log, counted."""
    import tempfile
    from pathlib import Path

    from rwhonet.data.drivefile import _size_bytes

    with tempfile.TemporaryDirectory() as d:
        root = Path(d)
        (root / "wheels.csv").write_bytes(b"x" * 100)
        (root / "gps.nmea").write_bytes(b"x" * 20)
        for name in ("can0.log", "can0.log.1", "can1.asc.gz", "bus.blf", "x.trc"):
            (root / name).write_bytes(b"x" * 1000)
        (root / "rx.log").write_bytes(
            b"#BESTPOSA,COM1,0,55.0,FINESTEERING,2167,318043.000,02000020,cdba,32768;x\n" + b"x" * 3
        )
        novatel = (root / "rx.log").stat().st_size
        assert _size_bytes(root, True, True) == 120 + novatel
        assert _size_bytes(root, True, False) == 120 + 5000 + novatel
        assert _size_bytes(root / "can0.log", False, True) == 0
        # a drive out of memory is told its whole size
        from rwhonet.data.drivefile import DriveFile, out_of_memory

        (problem,) = out_of_memory(DriveFile("d", "target_test", "target", "f", root)).problems
        assert problem.found == f"out of memory on its {(5120 + novatel) / 2**20:.3g} MB"


@pytest.mark.parametrize("suffix", [".asc", ".trc"])
@pytest.mark.parametrize("utc_hour", [0, 1])
def test_a_start_in_the_hour_the_clocks_went_back_is_refused_not_guessed(
    tmp_path, suffix, utc_hour
):
    """CANalyzer (an ASC's date line) or PCAN-View (a TRC's $STARTTIME) starting at 02:30
    in Berlin on 27 October 2024, a wall time the clocks showed twice (00:30 and 01:30
    UTC): with local_zone Europe/Berlin the log is refused naming its start's line or
    column, both offsets and the fixed zones that say which; with the fixed zone the
    logger kept (Etc/GMT-2 the first time, Etc/GMT-1 the second) its frames are on UTC
    at the stamps they were logged at."""
    from datetime import UTC, datetime

    from support.canlog import write_asc_in_zone

    start = datetime(2024, 10, 27, utc_hour, 30, tzinfo=UTC).timestamp()
    kept = "Etc/GMT-2" if utc_hour == 0 else "Etc/GMT-1"
    stamps, ids, data = can_frames(wavy_drive(5.0), RADIUS_M, start + 0.5)
    log = tmp_path / f"bus{suffix}"
    if suffix == ".asc":
        first = write_asc_in_zone(stamps, ids, data, log, kept)
        assert first == start
        stamps = np.r_[start, stamps]
        where = "row 1"
    else:
        write_bus_log(stamps, ids, data, log)
        # python-can's offsets count from the first frame: 02:30:00.5 on the wall
        days = (stamps[0] + 3600.0 * (2 if utc_hour == 0 else 1)) / 86400.0 + 25569.0
        lines = log.read_text().splitlines()
        at = next(i for i, x in enumerate(lines) if x.startswith(";$STARTTIME="))
        lines[at] = f";$STARTTIME={days:.10f}"
        lines = [x for x in lines if not x.startswith((";   Start time:", ";   Generated"))]
        log.write_text("\n".join(lines) + "\n")  # PCAN-View's: its start the local clock's
        where = "column '$STARTTIME'"
    with pytest.raises(InputError) as err:
        read_frames(log, log.name, "Europe/Berlin")
    said = str(err.value)
    assert f"bus{suffix}, {where}" in said
    assert "found 2024-10-27T02:30:00" in said  # (a TRC's start: to its ten decimals)
    assert " in Europe/Berlin, in the hour its clocks went back: UTC+2 or UTC+1" in said
    assert "Etc/GMT-2 (UTC+2) or Etc/GMT-1 (UTC+1)" in said
    frames = read_frames(log, log.name, kept)
    np.testing.assert_allclose(frames.t_s, stamps, rtol=0, atol=1e-5)


@pytest.mark.parametrize("suffix", [".asc", ".log"])
def test_a_frame_shorter_than_its_message_is_passed_over_not_decoded_from_zeros(tmp_path, suffix):
    """A logger that lost power cuts its last line (an ASC's ``d 8 43 EA``: two of eight
    bytes), a damaged candump line holds two bytes (``600#43EA``): decoded, the signals
    past the frame's end came from zeros, a fix at latitude 0.006. Such a frame is passed
    over and counted, named by its row, message and bytes (for predict too), and the
    drive's other frames read as they were."""
    df = wavy_drive(10.0)
    stamps, ids, data = can_frames(df, RADIUS_M, T0_S)
    log = write_bus_log(stamps, ids, data, tmp_path / f"bus{suffix}")
    (tmp_path / "bus.dbc").write_text(DBC)
    dbc = [str(tmp_path / "bus.dbc")]
    lines = log.read_text().splitlines()
    fix_lines = [i for i, x in enumerate(lines) if " 600 " in x or " 600#" in x]
    at = fix_lines[-1] if suffix == ".asc" else fix_lines[40]
    whole = read_mdf4(log, _signals(), RADIUS_M, NAME, log.name, dbc)
    if suffix == ".asc":  # cut in its data, as the last line a logger wrote
        cut = lines[at][: lines[at].index(" d 8 ") + len(" d 8 43 EA")]
        log.write_text("\n".join([*lines[:at], cut]))
    else:
        head, _ = lines[at].split("#")
        lines[at] = head + "#43EA"
        log.write_text("\n".join(lines) + "\n")
    got = read_mdf4(log, _signals(), RADIUS_M, NAME, log.name, dbc)
    first = next(i for i, x in enumerate(lines) if " 1A0 " in x or " 1A0#" in x)
    row = at + 1 if suffix == ".log" else at - first + 1  # an ASC's frames by their number
    said = (
        f"{log.name}: passed over: 1 frames shorter than their message in the CAN database, "
        f"not decoded (first at row {row}: GnssPos 0x600, 2 of 8 bytes)"
    )
    assert said in got.notes and said in got.changed
    kept = np.ones(whole.gnss.t_s.size, bool)
    kept[fix_lines.index(at)] = False
    np.testing.assert_array_equal(got.gnss.t_s, whole.gnss.t_s[kept])
    np.testing.assert_array_equal(
        got.gnss.channels[c.LAT_DEG], whole.gnss.channels[c.LAT_DEG][kept]
    )
    assert got.gnss.channels[c.LAT_DEG].min() > 52.0
    never = [x for x in lines[at + 1 :] if " Rx " in x] if suffix == ".asc" else []  # cut off
    assert got.wheels[0].t_s.size == whole.wheels[0].t_s.size - sum(" 1A0 " in x for x in never)
    # the short frame is one of the log's data frames, not decoded
    n = len(ids) - len(never)
    bus = "(0)" if suffix == ".asc" else "(can0)"
    assert f"{log.name}: {n} data frames on 1 bus(es) {bus}" in got.notes
    assert any(note.startswith(f"{log.name}: {n - 1} of them decoded") for note in got.notes)


def test_a_message_every_frame_of_which_is_short_is_refused_naming_it(tmp_path):
    """An ECU that sends the fix in 6 bytes where the database says 8: every one of its
    frames passed over would leave Lat and Lon missing, refused as "no such signal". It
    is refused naming the message, its length, the frames and the first one's row."""
    df = wavy_drive(10.0)
    log = write_bus_log(*can_frames(df, RADIUS_M, T0_S), tmp_path / "bus.log")
    lines = [
        x.split("#")[0] + "#" + x.split("#")[1][:12] if " 600#" in x else x
        for x in log.read_text().splitlines()
    ]
    log.write_text("\n".join(lines) + "\n")
    (tmp_path / "bus.dbc").write_text(DBC)
    with pytest.raises(InputError) as err:
        read_mdf4(log, _signals(), RADIUS_M, NAME, "bus.log", [str(tmp_path / "bus.dbc")])
    (problem,) = err.value.problems
    first = next(i for i, x in enumerate(lines) if " 600#" in x)
    assert (problem.file, problem.row) == ("bus.log", first + 1)
    assert problem.expected == "frames of GnssPos 0x600 of its 8 bytes in the CAN database"
    n = sum(" 600#" in x for x in lines)
    assert problem.found == f"every one of its {n} frames shorter (this row's: 6 bytes)"

"""Fuzzing the stream CSV reader and resampler: any edit of a good drive reads or is refused.

A good drive of one CSV per stream (wheel speeds at 100 Hz, fixes at 10 Hz:
``support.stream_corpus``) gets random edits of the kind loggers and exports
make, several at once: lines dropped, repeated, swapped, shuffled or written
late, the header line again, a cell made text, empty, NaN, inf or huge, the
file cut mid-line, bytes flipped. Whatever comes out, reading and resampling it
(as ingest and ``rwhonet predict`` do) either gives a 10 Hz grid whose columns
have one length and whose times increase, or raises
:class:`~rwhonet.errors.InputError` whose problems name a file of the drive and
say what to do; never another exception, never a hang.
"""

from __future__ import annotations

import tempfile
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from rwhonet.data import canonical as c
from rwhonet.errors import InputError
from rwhonet.sim.streams import StreamTables
from support.fuzz import (
    GOOD_STREAMS,
    STREAM_FILES,
    edited_log,
    edited_messages,
    edited_stream_drives,
    fuzz_settings,
    grid_or_clear_refusal,
    names_only,
    nothing_on_stdout,
)
from support.stream_corpus import folder_of, good_tables, read_case, write_good

FUZZ = fuzz_settings(40, deadline_ms=5000)


@FUZZ
@given(files=edited_stream_drives())
def test_an_edited_stream_drive_reads_or_is_refused_clearly(files, capfd):
    capfd.readouterr()
    with tempfile.TemporaryDirectory() as tmp, nothing_on_stdout(capfd):
        root = _stream_folder(Path(tmp), files)
        grid_or_clear_refusal(
            lambda: read_case("csv", root).drive, names_only({*STREAM_FILES, "streams"})
        )


def test_stream_files_whose_headers_cannot_be_read_are_refused_naming_each(tmp_path, capfd):
    """Both stream files' first byte a NUL (a logger that lost power writing them): each
    refused naming it. Found by this fuzz with 2,000 examples at stop 69: the columns the
    map names were refused too, "in none of them", naming no file at all."""
    capfd.readouterr()
    with tempfile.TemporaryDirectory() as tmp:
        folder = write_good("csv", Path(tmp))
        files = {name: (folder / name).read_bytes() for name in STREAM_FILES}
    files = {name: b"\x00" + data[1:] for name, data in files.items()}
    with nothing_on_stdout(capfd), pytest.raises(InputError) as err:
        read_case("csv", _stream_folder(tmp_path, files))
    assert {p.file for p in err.value.problems} == set(STREAM_FILES)
    assert all("NUL bytes" in p.found for p in err.value.problems)


def _stream_folder(root: Path, files: dict[str, bytes]) -> Path:
    """``files`` written as the stream folder of a case under ``root``; returns ``root``."""
    folder = folder_of("csv", root)
    folder.mkdir(parents=True)
    for name, data in files.items():
        (folder / name).write_bytes(data)
    return root


@st.composite
def edited_tables(draw) -> StreamTables:
    """The good drive's two streams with 1-4 random edits of their samples (as a logger
    writes an MDF4 file: rows dropped, repeated, swapped, shuffled or written late, a value
    NaN, inf or 1e300)."""
    good = good_tables()
    frames = {"wheels": good.wheels.copy(), "gnss": good.gnss.copy()}
    for _ in range(draw(st.integers(1, 4))):
        name = draw(st.sampled_from(sorted(frames)))
        df = frames[name]
        n = len(df)
        if n < 3:
            continue
        a = draw(st.integers(0, n - 2))
        b = min(n, a + draw(st.integers(1, 300)))
        kind = draw(st.sampled_from(["drop", "repeat", "swap", "shuffle", "late", "cell"]))
        order = np.arange(n)
        if kind == "drop":
            order = np.r_[order[:a], order[b:]]
        elif kind == "repeat":
            order = np.r_[order[:b], order[a:]]
        elif kind == "swap":
            order[a], order[b - 1] = order[b - 1], order[a]
        elif kind == "shuffle":
            order[a:b] = order[a:b][list(draw(st.permutations(range(b - a))))]
        elif kind == "late":
            order = np.insert(np.delete(order, a), min(n - 1, a + draw(st.integers(1, 40))), a)
        else:
            column = draw(st.sampled_from([k for k in df.columns if k != c.T_S]))
            df.loc[df.index[a], column] = draw(st.sampled_from([np.nan, np.inf, 1e300, -1.0]))
        frames[name] = df.iloc[order].reset_index(drop=True)
    return StreamTables(frames["wheels"], frames["gnss"])


@FUZZ
@given(tables=edited_tables(), cut=st.one_of(st.none(), st.floats(0.0, 1.0)))
def test_an_edited_mdf4_drive_reads_or_is_refused_clearly(tables, cut, capfd):
    capfd.readouterr()
    with tempfile.TemporaryDirectory() as tmp, nothing_on_stdout(capfd):
        root = Path(tmp)
        path = write_good("mdf4", root, tables)
        if cut is not None:  # the logger lost power: the file ends early
            data = path.read_bytes()
            path.write_bytes(data[: int(cut * len(data))])
        grid_or_clear_refusal(
            lambda: read_case("mdf4", root).drive, lambda p: p.file.startswith("drive.mf4")
        )


def _good_nmea_lines(
    sentences: tuple[str, ...], stamped: bool = True, utc0_s: float = 1_552_262_400.0
) -> list[str]:
    """The good drive's fixes as the receiver's NMEA log, each line after the stamp (else
    unstamped), the fixes' UTC times from ``utc0_s``."""
    from support.nmea import nmea_lines

    gnss = good_tables().gnss
    t = gnss[c.T_S].to_numpy()
    return nmea_lines(gnss, utc0_s + t, sentences, stamps=t if stamped else None)


@st.composite
def edited_nmea_logs(draw, stamped: bool = True, utc0_s: float = 1_552_262_400.0) -> bytes:
    """The good drive's NMEA log with 1-5 random edits (:func:`support.fuzz.edited_log`),
    and its own: a field changed (its checksum mended or not), a stamp changed or gone.
    The receiver writes GGA and RMC, or GNS, RMC and GLL."""
    from support.nmea import sentence

    def edit(draw, rows: list[str], kind: str, a: int) -> None:
        stamp, body = rows[a].split("$", 1)
        if kind == "field":
            fields = body.split("*")[0].split(",")
            fields[draw(st.integers(1, len(fields) - 1))] = draw(
                st.sampled_from(["", "x", "nan", "1e300", "-5", "9999.9", "V", "0", "6"])
            )
            mended = sentence(",".join(fields))
            rows[a] = stamp + (mended if draw(st.booleans()) else "$" + mended[1:-2] + "00")
        else:  # stamp
            rows[a] = draw(st.sampled_from(["", "x,", "nan,", "-1,", "1e300,"])) + "$" + body

    kinds = draw(st.sampled_from([("GGA", "RMC"), ("GNS", "RMC", "GLL")]))
    rows = _good_nmea_lines(kinds, stamped, utc0_s)
    return edited_log(draw, rows, ("field", "stamp"), edit, "\r\n")


@FUZZ
@given(log=edited_nmea_logs())
def test_an_edited_nmea_log_reads_or_is_refused_clearly(log, capfd):
    """The good drive's wheels.csv and its fixes as an NMEA log with random edits."""
    from rwhonet.sim.streams import signal_map

    capfd.readouterr()
    with tempfile.TemporaryDirectory() as tmp, nothing_on_stdout(capfd):
        root = Path(tmp)
        write_good("csv", root)
        folder = folder_of("csv", root)
        (folder / "gnss.csv").unlink()
        (folder / "gps.nmea").write_bytes(log)
        files = [folder / "wheels.csv", folder / "gps.nmea"]
        named = names_only({"wheels.csv", "gps.nmea", "streams"})
        _grid_or_clear_refusal_of(files, signal_map(), named)


CAN_CLOCK_S = 1_700_000_000.0  # the candump log's Unix clock at the good drive's 0 s


def _good_candump_lines(wheels_only: bool = False) -> list[str]:
    """The good drive's streams (or its wheels alone) as raw CAN frames in a candump log
    (support.canlog)."""
    from support.canlog import stream_frames
    from support.stream_corpus import RADIUS_M

    good = good_tables()
    tables = StreamTables(good.wheels, good.gnss.iloc[:0]) if wheels_only else good
    stamps, ids, data = stream_frames(tables, RADIUS_M, CAN_CLOCK_S)
    return [
        f"({t:.6f}) can0 {i:03X}#{bytes(d).hex().upper()}"
        for t, i, d in zip(stamps.tolist(), ids.tolist(), data, strict=True)
    ]


@st.composite
def edited_candump_logs(draw, wheels_only: bool = False) -> bytes:
    """The good drive's candump log with 1-5 random edits (:func:`support.fuzz.edited_log`),
    and its own: a line's identifier, data or stamp changed."""

    def edit(draw, rows: list[str], kind: str, a: int) -> None:
        stamp, bus, frame = rows[a].split(" ")
        ident, payload = frame.split("#", 1)
        new = draw(st.sampled_from(["", "x", "R", "#", "20000080", "1FFFFFFFF", "00" * 9]))
        if kind == "id":
            ident = new
        elif kind == "data":
            payload = new
        else:
            stamp = f"({new})"
        rows[a] = f"{stamp} {bus} {ident}#{payload}"

    rows = _good_candump_lines(wheels_only)
    return edited_log(draw, rows, ("id", "data", "stamp"), edit, "\n")


@FUZZ
@given(log=edited_candump_logs())
def test_an_edited_candump_log_reads_or_is_refused_clearly(log, capfd):
    """The good drive's frames as a candump log with random edits, decoded with its DBC."""
    from rwhonet.config import ColumnSpec
    from rwhonet.data.mdf4 import read_mdf4
    from rwhonet.data.streams import resample
    from support.canlog import DBC, SIGNALS
    from support.stream_corpus import RADIUS_M

    capfd.readouterr()
    with tempfile.TemporaryDirectory() as tmp, nothing_on_stdout(capfd):
        root = Path(tmp)
        (root / "bus.log").write_bytes(log)
        (root / "bus.dbc").write_text(DBC)
        signals = {k: ColumnSpec(**v) for k, v in SIGNALS.items()}

        def read():
            dbc = [str(root / "bus.dbc")]
            streams = read_mdf4(root / "bus.log", signals, RADIUS_M, display="bus.log", dbc=dbc)
            return resample(streams, nominal_radius_m=RADIUS_M).drive

        grid_or_clear_refusal(read, lambda p: p.file.startswith(("bus.log", "streams")))


@pytest.mark.parametrize("in_ubx", [False, True])
@FUZZ
@given(
    can=edited_candump_logs(wheels_only=True),
    nmea=edited_nmea_logs(stamped=False, utc0_s=CAN_CLOCK_S),
)
def test_an_edited_candump_log_beside_an_edited_nmea_log_reads_or_is_refused_clearly(
    in_ubx, can, nmea, capfd
):
    """A Linux logger's folder: the wheels' frames in can0.log on a Unix clock, the
    receiver's unstamped NMEA log placed by its UTC times; both with random edits. Or
    (``in_ubx``) u-center's .ubx of the receiver's NMEA output: the edited log with binary
    NAV-TIMEUTC and NAV-DOP messages before each GGA on its line."""
    if not in_ubx:
        _beside_a_candump_log(can, "gps.nmea", nmea, capfd)
        return
    from support.ubx import other_messages

    lines = nmea.split(b"\n")
    ubx = b"\n".join(
        other_messages(1000 * i) + x if b"GGA," in x else x for i, x in enumerate(lines)
    )
    _beside_a_candump_log(can, "gps.ubx", ubx, capfd)


def _beside_a_candump_log(can: bytes, name: str, log: bytes, capfd) -> None:
    """A Linux logger's folder (can0.log and the receiver's log ``name``, the map's DBC)
    read as ingest and predict read it: a grid, or a refusal naming its files."""
    from rwhonet.config import ColumnSpec
    from support.canlog import DBC

    capfd.readouterr()
    with tempfile.TemporaryDirectory() as tmp, nothing_on_stdout(capfd):
        root = Path(tmp)
        (root / "can0.log").write_bytes(can)
        (root / name).write_bytes(log)
        (root / "bus.dbc").write_text(DBC)
        signals = {"t": ColumnSpec("t", "s")} | {
            f"omega_{w}": ColumnSpec(f"WhlSpd_{w.upper()}", "km/h")
            for w in ("fl", "fr", "rl", "rr")
        }
        files = [root / "can0.log", root / name]
        named = lambda p: p.file.startswith(("can0.log", name, "streams"))  # noqa: E731
        _grid_or_clear_refusal_of(files, signals, named, [str(root / "bus.dbc")])


@cache
def _good_ubx_messages(receiver: str) -> tuple[bytes, ...]:
    """The good drive's fixes as a u-blox receiver's log (pyubx2), an epoch's messages a
    row: NAV-TIMEUTC, NAV-DOP and NAV-PVT (``u-blox 8``); NAV-POSLLH, NAV-SOL, NAV-VELNED
    and NAV-TIMEUTC (``u-blox 6``). Their UTC times from :data:`CAN_CLOCK_S`."""
    from support.ubx import u6_messages, ubx_messages

    gnss = good_tables().gnss
    write = ubx_messages if receiver == "u-blox 8" else u6_messages
    return tuple(write(gnss, CAN_CLOCK_S + gnss[c.T_S].to_numpy()))


@st.composite
def edited_ubx_logs(draw) -> bytes:
    """The good drive's UBX log (a u-blox 8's or a u-blox 6's) with 1-5 random edits:
    epochs' messages dropped, repeated, swapped, shuffled or written late
    (:data:`support.fuzz.LINE_EDITS`, an epoch's messages as a line), a payload byte of
    one of an epoch's messages set (its checksum mended or not: any field, a date, a flag,
    a coordinate out of range), a byte flipped, the file cut
    (:func:`support.fuzz.edited_messages`)."""

    def edit(draw, rows: list[bytes], a: int) -> None:
        epoch = bytearray(rows[a])
        starts = [0]  # the epoch's messages: sync, class, id, length, payload, checksum
        while starts[-1] + 8 + int.from_bytes(
            epoch[starts[-1] + 4 : starts[-1] + 6], "little"
        ) < len(epoch):
            starts.append(
                starts[-1] + 8 + int.from_bytes(epoch[starts[-1] + 4 : starts[-1] + 6], "little")
            )
        m = draw(st.sampled_from(starts))
        n = int.from_bytes(epoch[m + 4 : m + 6], "little")
        epoch[m + 6 + draw(st.integers(0, n - 1))] = draw(st.integers(0, 255))
        if draw(st.booleans()):  # the checksum mended: a well-formed message
            ck_a = ck_b = 0
            for x in epoch[m + 2 : m + 6 + n]:
                ck_a = (ck_a + x) & 0xFF
                ck_b = (ck_b + ck_a) & 0xFF
            epoch[m + 6 + n : m + 8 + n] = bytes([ck_a, ck_b])
        rows[a] = bytes(epoch)

    rows = list(_good_ubx_messages(draw(st.sampled_from(["u-blox 8", "u-blox 6"]))))
    return edited_messages(draw, rows, edit)


@FUZZ
@given(can=edited_candump_logs(wheels_only=True), ubx=edited_ubx_logs())
def test_an_edited_candump_log_beside_an_edited_ubx_log_reads_or_is_refused_clearly(
    can, ubx, capfd
):
    """A Linux logger's folder: the wheels' frames in can0.log on a Unix clock, the
    u-blox receiver's binary log placed by its iTOW on UTC; both with random edits."""
    _beside_a_candump_log(can, "gps.ubx", ubx, capfd)


def _grid_or_clear_refusal_of(files, signals, named, dbc=()) -> None:
    """A stream folder's ``files`` (each named by its own name) read and resampled as
    ingest and predict do: a grid, or a refusal whose problems are all ``named``."""
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample
    from support.stream_corpus import RADIUS_M

    shown = {p: p.name for p in files}

    def read():
        streams = read_stream_csvs(files, signals, RADIUS_M, display=shown, dbc=dbc)
        return resample(streams, nominal_radius_m=RADIUS_M).drive

    grid_or_clear_refusal(read, named)


@st.composite
def rotations(draw) -> dict[str, list[tuple[int, int, str, int]]]:
    """How a logger rotating its files cuts the good drive's two files: for each, the cuts
    (data rows), and per file after the first one habit at its cut: none, the last 1-3 rows
    written into both files (``both``), 1-20 rows lost (``lost``), or (two loggers) the file
    starting 1-5 rows early with other values (``other``); and the files' names in an order
    that is not their time order. File -> ``[(cut, order, habit, count)]``."""
    plan = {}
    for name, (_, *rows) in GOOD_STREAMS.items():
        n = len(rows)
        cuts = sorted(draw(st.sets(st.integers(50, n - 50), min_size=0, max_size=3)))
        if len(cuts) > 1 and min(np.diff(cuts)) < 30:
            cuts = cuts[:1]
        order = draw(st.permutations(range(len(cuts) + 1)))
        habits = [("none", 0)] + [
            draw(
                st.one_of(
                    st.just(("none", 0)),
                    st.tuples(st.just("both"), st.integers(1, 3)),
                    st.tuples(st.just("lost"), st.integers(1, 20)),
                    st.tuples(st.just("other"), st.integers(1, 5)),
                )
            )
            for _ in cuts
        ]
        plan[name] = [
            (lo, o, h, k) for lo, o, (h, k) in zip([0, *cuts], order, habits, strict=True)
        ]
    return plan


def _rotated(plan) -> dict[str, bytes]:
    """The files of :func:`rotations`' plan."""
    out = {}
    for name, (header, *rows) in GOOD_STREAMS.items():
        parts = plan[name]
        ends = [lo for lo, *_ in parts[1:]] + [len(rows)]
        for (lo, order, habit, count), hi in zip(parts, ends, strict=True):
            part = list(rows[lo:hi])
            if habit == "both":
                part = rows[lo - count : lo] + part
            elif habit == "lost":
                del part[:count]
            elif habit == "other":
                part = [
                    ",".join([r.split(",")[0], *(f"{float(x) + 0.25!r}" for x in r.split(",")[1:])])
                    for r in rows[lo - count : lo]
                ] + part
            out[f"{name.removesuffix('.csv')}_{order}.csv"] = (
                "\n".join([header, *part]) + "\n"
            ).encode()
    return out


@FUZZ
@given(plan=rotations())
def test_a_stream_split_across_files_reads_as_the_one_file_or_is_refused_clearly(plan, capfd):
    """Rotated files read as the one file's drive, bit for bit, where no sample was lost or
    written with other values; two files overlapping with other values are refused, naming
    the files; rows lost at a rotation give a grid or a clear refusal."""
    files = _rotated(plan)
    habits = {h for parts in plan.values() for _, _, h, _ in parts}
    capfd.readouterr()
    with tempfile.TemporaryDirectory() as tmp, nothing_on_stdout(capfd):
        root = _stream_folder(Path(tmp), files)
        if "other" in habits:
            with pytest.raises(InputError) as err:
                read_case("csv", root)
            assert any("the files overlap by" in p.found for p in err.value.problems)
            assert all(names_only(set(files))(p) for p in err.value.problems)
            return
        if "lost" in habits:
            grid_or_clear_refusal(lambda: read_case("csv", root).drive, names_only(set(files)))
            return
        got = read_case("csv", root).drive.columns
    with tempfile.TemporaryDirectory() as tmp:
        write_good("csv", Path(tmp))
        want = read_case("csv", Path(tmp)).drive.columns
    assert got.keys() == want.keys()
    for k in want:
        np.testing.assert_array_equal(got[k], want[k], err_msg=k)


@cache
def _good_gpx_lines() -> tuple[str, ...]:
    """The good drive's fixes as a GPX 1.0 track (gpxpy's), one line a point (its elements
    joined), the header's and the closing tags' lines around them; UTC from
    :data:`CAN_CLOCK_S`."""
    from support.gpx import track

    gnss = good_tables().gnss
    text = track(gnss, CAN_CLOCK_S + gnss[c.T_S].to_numpy()).to_xml("1.0")
    lines: list[str] = []
    for line in text.splitlines():
        if lines and lines[-1].lstrip().startswith("<trkpt") and "</trkpt>" not in lines[-1]:
            lines[-1] += line.strip()
        else:
            lines.append(line)
    return tuple(lines)


@st.composite
def edited_gpx_tracks(draw) -> bytes:
    """The good drive's GPX track with 1-5 random edits (:func:`support.fuzz.edited_log`:
    lines, points among them, dropped, repeated, swapped, shuffled or written late; the
    file cut; a byte flipped), and its own: an element's or attribute's value changed (to
    nothing, text, NaN, a huge number, out of range, ``none``), a point's time changed."""
    import re

    def edit(draw, rows: list[str], kind: str, a: int) -> None:
        values = list(re.finditer(r'(?<=>)[^<]*(?=</)|(?<=")[^"]*(?=")', rows[a]))
        if not values:
            return
        v = draw(st.sampled_from(values))
        if kind == "value":
            new = draw(st.sampled_from(["", "x", "nan", "1e300", "-95", "200", "none", "2d"]))
        else:  # time
            new = draw(st.sampled_from(["", "2019-02-30T00:00:00Z", "12:00:00", "2023-11-14"]))
        rows[a] = rows[a][: v.start()] + new + rows[a][v.end() :]

    return edited_log(draw, list(_good_gpx_lines()), ("value", "time"), edit, "\n")


@FUZZ
@given(can=edited_candump_logs(wheels_only=True), gpx=edited_gpx_tracks())
def test_an_edited_candump_log_beside_an_edited_gpx_track_reads_or_is_refused_clearly(
    can, gpx, capfd
):
    """A Linux logger's folder: the wheels' frames in can0.log on a Unix clock, a phone
    logger's GPX track placed by its UTC times; both with random edits."""
    _beside_a_candump_log(can, "track.gpx", gpx, capfd)


@cache
def _good_novatel_logs(binary: bool) -> tuple:
    """The good drive's fixes as a NovAtel receiver's logs (TIMEA and BESTPOSA an epoch; or
    their binary forms), UTC from :data:`CAN_CLOCK_S`; their CRCs, computed bit by bit, once."""
    from support.novatel import novatel_binary, novatel_lines

    gnss = good_tables().gnss
    t = CAN_CLOCK_S + gnss[c.T_S].to_numpy()
    return tuple(novatel_binary(gnss, t) if binary else novatel_lines(gnss, t))


@st.composite
def edited_novatel_logs(draw) -> bytes:
    """The good drive's fixes as a NovAtel receiver's ASCII logs (TIMEA, BESTPOSA) with 1-5
    random edits (:func:`support.fuzz.edited_log`), and its own: a field changed, its CRC
    mended or not."""
    from support.novatel import crc32

    def edit(draw, rows: list[str], kind: str, a: int) -> None:
        body = rows[a][1:].rsplit("*", 1)[0]
        head, _, tail = body.partition(";")
        fields = tail.split(",")
        fields[draw(st.integers(0, len(fields) - 1))] = draw(
            st.sampled_from(["", "x", "nan", "1e300", "-95", "200", "NONE", "PROPAGATED"])
        )
        body = f"{head};{','.join(fields)}"
        crc = crc32(body.encode()) if draw(st.booleans()) else 0
        rows[a] = f"#{body}*{crc:08x}"

    return edited_log(draw, list(_good_novatel_logs(False)), ("field",), edit, "\r\n")


@FUZZ
@given(can=edited_candump_logs(wheels_only=True), log=edited_novatel_logs())
def test_an_edited_candump_log_beside_an_edited_novatel_log_reads_or_is_refused_clearly(
    can, log, capfd
):
    """A Linux logger's folder: the wheels' frames in can0.log on a Unix clock, a NovAtel
    receiver's logs (drive.gps) placed by their GPS weeks on UTC; both with random edits."""
    _beside_a_candump_log(can, "drive.gps", log, capfd)


@st.composite
def edited_novatel_binary_logs(draw) -> bytes:
    """The good drive's fixes as a NovAtel receiver's binary logs (TIMEB, BESTPOSB a
    message each) with 1-5 random edits: messages dropped, repeated, swapped, shuffled or
    written late (:data:`support.fuzz.LINE_EDITS`), a byte of one set (its CRC mended or
    not), a byte flipped, the file cut."""
    from support.novatel import crc32

    def edit(draw, rows: list[bytes], a: int) -> None:
        m = bytearray(rows[a])
        m[draw(st.integers(3, len(m) - 5))] = draw(st.integers(0, 255))
        if draw(st.booleans()):
            m[-4:] = crc32(bytes(m[:-4])).to_bytes(4, "little")
        rows[a] = bytes(m)

    return edited_messages(draw, list(_good_novatel_logs(True)), edit)


@FUZZ
@given(can=edited_candump_logs(wheels_only=True), log=edited_novatel_binary_logs())
def test_an_edited_candump_log_beside_an_edited_novatel_binary_log_reads_or_is_refused_clearly(
    can, log, capfd
):
    """The same folder with the NovAtel receiver's binary logs (drive.gps)."""
    _beside_a_candump_log(can, "drive.gps", log, capfd)

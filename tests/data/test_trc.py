"""A PEAK TRC log read over its lines at once, in each version of PEAK's format
(rwhonet.data.trc): python-can's frames where python-can reads the log, and the logs it
refused whole (a remote frame in 1.x, an error frame in 1.0, a 1.2 log) read."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

from rwhonet.data import trc
from rwhonet.data.canlog import _python_can, read_frames
from rwhonet.errors import InputError
from support.canlog import assert_same_frames

# PEAK's "PEAK CAN TRC File Format" examples' lines, one log a version: a frame, an error
# frame, a bus warning, a remote frame, as each version writes them
PEAK = {
    "1.0": """\
;##########################################################################
;   C:\\TraceFile.trc
;   Start time: 11.09.2002 16:00:20.682
;----+-   ---+---  ----+---  +  -+ -- -- ...
     1)      1841      0001  8  00 11 22 33 44 55 66 77
     2)      1842      0008  4  ERROR 00 19 08 08
     3)      1843  FFFFFFFF  4  00 00 00 04 -- -- -- --  BUSLIGHT
     4)      1844      0100  3  RTR
     5)      1845  00012345  2  A0 B1
""",
    "1.1": """\
;$FILEVERSION=1.1
;$STARTTIME=37704.5364870833
;   Start time: 24.03.2003 12:52:32.484
;---+--   ----+----  --+--  ----+---  +  -+ -- -- -- -- -- -- --
     1)      1059.9  Rx         0300  7  00 00 00 00 04 00 00
     2)      1298.9  Tx         0400  2  00 00
     3)      1346.8  Warng  FFFFFFFF  4  00 00 00 04  BUSLIGHT
     4)      1349.2  Error      0008  4  00 19 08 08
     5)      1352.7  Rx         0100  3  RTR
     6)      1353.0  Rx     18EFC034  8  01 02 03 04 05 06 07 08
""",
    "1.2": """\
;$FILEVERSION=1.2
;$STARTTIME=39878.6772258947;
;   Start time: 06.03.2009 16:15:12.317.3
     1)      1059.900  1  Rx         0300  7  00 00 00 00 04 00 00
     2)      1298.945  2  Tx         0400  2  00 00
     3)      1346.834  1  Warng  FFFFFFFF  4  00 00 00 04  BUSLIGHT
     4)      1349.222  1  Error      0008  4  00 19 08 08
     5)      1352.743  1  Rx         0100  3  RTR
     6)      1353.000  1  Rx     18EFC034  8  01 02 03 04 05 06 07 08
""",
    "1.3": """\
;$FILEVERSION=1.3
;$STARTTIME=40023.5245451516
;   Start time: 29.07.2009 12:35:20.701.0
     1)      1059.900 1  Rx        0300 -  7    00 00 00 00 04 00 00
     2)      1298.945 2  Tx        0400 -  2    00 00
     3)      1346.834 1  Warng FFFFFFFF -  4    00 00 00 04  BUSLIGHT
     4)      1349.222 1  Error     0008 -  4    00 19 08 08
     5)      1352.743 1  Rx        0100 -  3    RTR
     6)      1353.000 1  Rx    18EFC034 -  8    01 02 03 04 05 06 07 08
""",
    "2.0": """\
;$FILEVERSION=2.0
;$STARTTIME=42209.4075997106
;$COLUMNS=N,O,T,I,d,l,D
      1      1059.900 DT     0300 Rx 7  00 00 00 00 04 00 00
      2      1298.945 DT     0400 Tx 2  00 00
      3      1334.416 FD     0500 Tx 12 01 02 03 04 05 06 07 08 09 0A 0B 0C
      4      1334.522 ER          Rx    04 00 02 00 00
      5      1334.531 ST          Rx    00 00 00 08
      6      1334.643 EC          Rx    02 02
      7      1335.156 DT 18EFC034 Tx 8  01 02 03 04 05 06 07 08
      8      1336.543 RR     0100 Rx 3
""",
    "2.1": """\
;$FILEVERSION=2.1
;$STARTTIME=41766.4648963872
;$COLUMNS=N,O,T,B,I,d,R,L,D
      1      1059.900 DT 1      0300 Rx -  7    00 00 00 00 04 00 00
      2      1298.945 DT 2      0400 Tx -  2    00 00
      3      1334.416 FD 1      0500 Tx -  9    01 02 03 04 05 06 07 08 09 0A 0B 0C
      4      1334.222 ER 1         - Rx -  5    04 00 02 00 00
      5      1334.224 EV 1  User-defined event for bus 1
      6      1334.225 EV -  User-defined event for all busses
      7      1334.231 ST 1         - Rx -  4    00 00 00 08
      8      1334.643 EC 1         - Rx -  2    02 02
      9      1335.156 BI 1  18EFC034 Tx -  8    01 02 03 04 05 06 07 08
     10      1336.543 RR 1      0100 Rx -  3
""",
}
# the start each header's $STARTTIME gives, as the "Start time" comment beside it says
STARTS = {
    "1.1": "2003-03-24 12:52:32.484",
    "1.2": "2009-03-06 16:15:12.317",
    "1.3": "2009-07-29 12:35:20.701",
    "2.0": "2015-07-24 09:46:56.615",
    "2.1": "2014-05-07 11:09:27.047",  # PEAK's example's comment says 2015: 41766 is 2014
}


def _frames(version: str) -> trc.TrcFrames:
    return trc.trc_frames(PEAK[version].encode(), "bus.trc")


@pytest.mark.parametrize("version", list(PEAK))
def test_peak_s_example_of_each_version_reads_as_peak_s_format_says(version):
    """Each version's frames, with their offsets, identifiers (extended above 4 digits),
    lengths (an FD frame's DLC 9: 12 bytes; 2.0's l: the bytes), buses and lines; error
    frames, remote frames, warnings, status and event lines passed over and counted."""
    got = _frames(version)
    fd = version.startswith("2")
    want_ids = [0x300, 0x400, *([0x500] if fd else []), 0x18EFC034]
    want_len = [7, 2, *([12] if fd else []), 8]
    if version == "1.0":
        want_ids, want_len = [0x0001, 0x12345], [8, 2]
    assert got.ids.tolist() == want_ids
    assert got.length.tolist() == want_len
    assert got.extended.tolist() == [len(f"{i:X}") > 3 for i in want_ids]
    assert got.version == version
    assert got.passed["error frames"] == 1 and got.passed["remote frames"] == 1
    assert got.passed["bus status and event lines"] == {"2.0": 2, "2.1": 4}.get(version, 1)
    text = PEAK[version].splitlines()
    for row, ident in zip(got.rows.tolist(), got.ids.tolist(), strict=True):
        assert f"{ident:X}".zfill(4) in text[row - 1]  # each frame's own line
    if version == "1.0":
        assert got.start_s is None
        np.testing.assert_array_equal(got.t_s, [1.841, 1.845])
        assert got.data[1, :2].tolist() == [0xA0, 0xB1]
        return
    start = np.datetime64(STARTS[version]).astype("datetime64[us]").astype(float) / 1e6
    assert abs(got.start_s - start) < 1e-3  # the header's comment, to its millisecond
    assert got.t_s[0] == 1059.9 / 1000 + got.start_s
    assert got.data[0, :7].tolist() == [0, 0, 0, 0, 4, 0, 0]
    if fd:
        assert got.data[2, :12].tolist() == list(range(1, 13))
    if version in ("1.2", "1.3", "2.1"):
        assert got.bus.tolist()[:2] == [1, 2]


def _python_can_reads(path) -> bool:
    try:
        _python_can(path, path.name, ".trc")
    except InputError:
        return False
    return True


@pytest.mark.parametrize("version", list(PEAK))
def test_where_python_can_reads_a_log_the_frames_are_its_own(tmp_path, version):
    """PEAK's examples without their remote frames (and 1.0's error frame), and 1.2's
    header without PCAN-Explorer's ';': python-can's frames bit for bit, except the
    frames' rows (here their lines) and what was passed over (python-can says nothing).
    1.2 python-can reads as 1.0 and refuses; with the remote frames, it refuses every
    1.x log, which are read here."""
    lines = [x for x in PEAK[version].splitlines() if not x.endswith(("RTR", "08 08"))]
    whole = tmp_path / "whole.trc"
    whole.write_text(PEAK[version])
    assert _python_can_reads(whole) == version.startswith("2")
    if version != "1.0":  # a key written twice: the last counts, in python-can as here
        lines.insert(1, ";$STARTTIME=40000.25")
    path = tmp_path / "bus.trc"
    path.write_text("\n".join(x.rstrip(";") for x in lines) + "\n")
    got = read_frames(path, path.name)
    if version == "1.2":
        assert not _python_can_reads(path)  # read as 1.0: "Rx" is no DLC
        assert got.ids.tolist() == [0x300, 0x400, 0x18EFC034]
        return
    want = _python_can(path, path.name, ".trc")
    assert got.t_s.size == want.t_s.size > 0
    assert_same_frames(dataclasses.replace(got, rows=want.rows, passed="", clock=want.clock), want)
    # PEAK's tools write their start on the logging computer's local clock: read as UTC, as
    # python-can reads it, and marked so (python-can's own writer's, below, is UTC)
    local = "" if version == "1.0" else ", its $STARTTIME the logging computer's local clock"
    assert got.clock == want.clock + f", TRC {version}" + (local and local + ", read as UTC")
    assert got.local_start and not want.local_start


def _writer_log(path, version: str, n: int, seed: int):  # type: ignore[no-untyped-def]
    """``n`` random frames (standard and extended, 0-8 bytes, two channels for 2.1) as
    python-can's TRCWriter writes them (2.1, or 1.0)."""
    import can
    from can.io.trc import TRCFileVersion, TRCWriter

    rng = np.random.default_rng(seed)
    with open(path, "w") as fh:
        writer = TRCWriter(fh)
        if version == "1.0":
            writer.file_version = TRCFileVersion.V1_0
        t = 1.7e9
        for _ in range(n):
            t += float(rng.uniform(0, 0.003))
            ext = bool(rng.integers(2))
            msg = can.Message(
                timestamp=t,
                arbitration_id=int(rng.integers(0, 0x1FFFFFFF if ext else 0x7FF)),
                is_extended_id=ext,
                data=bytes(rng.integers(0, 256, int(rng.integers(0, 9))).tolist()),
                channel=int(rng.integers(1, 3)) if version == "2.1" else None,
            )
            writer.on_message_received(msg)
        writer.stop()
    return path


@pytest.mark.parametrize("version", ["2.1", "1.0"])
def test_python_can_s_writer_s_log_reads_as_python_can_reads_it(tmp_path, version):
    """2,000 random frames in python-can's TRC writer's 2.1 and 1.0 logs: the frames of
    python-can's reader, array for array; read in chunks of a few lines, the same."""
    path = _writer_log(tmp_path / "bus.trc", version, 2000, seed=int(version[0]))
    got = read_frames(path, path.name)
    want = _python_can(path, path.name, ".trc")
    assert got.t_s.size == 2000 and got.passed == ""
    assert got.local_start == (version == "1.0")  # 2.1: python-can's writer's start is UTC
    assert_same_frames(dataclasses.replace(got, rows=want.rows, clock=want.clock), want)
    header = 18 if version == "2.1" else 16
    np.testing.assert_array_equal(got.rows, want.rows + header)
    raw = path.read_bytes()
    whole = trc.trc_frames(raw, "bus.trc")
    old = trc.CHUNK_BYTES
    try:
        trc.CHUNK_BYTES = 300
        small = trc.trc_frames(raw, "bus.trc")
    finally:
        trc.CHUNK_BYTES = old
    for name in ("t_s", "ids", "extended", "length", "data", "bus", "rows"):
        np.testing.assert_array_equal(getattr(small, name), getattr(whole, name))


def test_damaged_lines_are_passed_over_counted_with_the_first():
    """An offset, identifier, bus, DLC or byte that is none, a byte missing, a classic
    frame of 9 bytes, an FD length FD has not, a type 2.1 has none of, a line cut short:
    passed over, counted with the first's line; the rest read."""
    lines = PEAK["2.1"].splitlines()[:3] + [
        "      1      1059.900 DT 1      0300 Rx -  2    AA BB",
        "      2      1059.9x0 DT 1      0300 Rx -  2    AA BB",
        "      3      1060.000 DT 1      03G0 Rx -  2    AA BB",
        "      4      1060.100 DT x      0300 Rx -  2    AA BB",
        "      5      1060.200 DT 1      0300 Rx -  z    AA BB",
        "      6      1060.300 DT 1      0300 Rx -  2    AA BX",
        "      7      1060.400 DT 1      0300 Rx -  2    AA",
        "      8      1060.500 DT 1      0300 Rx -  9    00 00 00 00 00 00 00 00 00",
        "      9      1060.600 FD 1      0300 Rx -  16   00",
        "     10      1060.700 XX 1      0300 Rx -  2    AA BB",
        "     11      1060.800 DT 1",
        "     12      1060.900 DT 1      0301 Rx -  0",
        "     13      1060.9.1 DT 1      0300 Rx -  2    AA BB",
        "     14      1061.000 DT 1      0300 Rx -  2    AA B",
        "; a comment among the frames",
        "",
        "     15      1061.000 DT 1      0302 Rx -  1    0C",
    ]
    got = trc.trc_frames("\r\n".join(lines).encode(), "bus.trc")
    assert got.ids.tolist() == [0x300, 0x301, 0x302]
    assert got.length.tolist() == [2, 0, 1]
    assert got.rows.tolist() == [4, 15, 20]
    assert got.passed == {
        "lines of a type TRC 2.1 has none of (first at line 13)": 1,
        "lines damaged (first at line 5)": 11,
    }
    said = read_frames_of(lines)
    assert said == (
        "1 lines of a type TRC 2.1 has none of (first at line 13), "
        "11 lines damaged (first at line 5)"
    )


def read_frames_of(lines: list[str]) -> str:
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "bus.trc"
        path.write_text("\n".join(lines) + "\n")
        return read_frames(path, path.name).passed


@pytest.mark.parametrize(
    ("header", "column", "expected"),
    [
        (";$FILEVERSION=3.0\n", "$FILEVERSION", "a version of PEAK's TRC format"),
        (
            ";$FILEVERSION=2.1\n;$STARTTIME=soon\n;$COLUMNS=N,O,T,B,I,d,R,L,D\n",
            "$STARTTIME",
            "days",
        ),
        (";$FILEVERSION=2.0\n", "$COLUMNS", "no $COLUMNS line"),
        (";$FILEVERSION=2.1\n;$COLUMNS=N,O,T,B,I,d,R,D,L\n", "$COLUMNS", "D (data) last"),
    ],
)
def test_a_header_the_format_has_not_is_refused_naming_its_line(tmp_path, header, column, expected):
    """A version PEAK's format has not (python-can read it as 1.0), a start that is no
    number, a 2.x log without the columns a frame needs: refused, naming the file, the
    header's line and key."""
    path = tmp_path / "bus.trc"
    path.write_text(header + "      1      1059.900 DT 1      0300 Rx -  2    AA BB\n")
    with pytest.raises(InputError) as err:
        read_frames(path, path.name)
    said = str(err.value)
    assert "bus.trc" in said and f"column '{column}'" in said and expected in said
    if column != "$COLUMNS" or "last" in expected:
        assert "row " in said


def test_a_log_of_no_frames_is_refused_saying_what_was_passed_over(tmp_path):
    path = tmp_path / "bus.trc"
    lines = [x for x in PEAK["2.1"].splitlines() if " DT " not in x and " FD " not in x]
    path.write_text("\n".join(x for x in lines if " BI " not in x) + "\n")
    with pytest.raises(InputError) as err:
        read_frames(path, path.name)
    assert "1 error frames, 1 remote frames, 4 bus status and event lines" in str(err.value)


def _python_can_line(reader, line: str):  # type: ignore[no-untyped-def]
    """python-can's reading of one message line, after its header (None: passed over)."""
    try:
        return reader._parse_line(line.strip())
    except Exception:
        return None


@pytest.mark.parametrize("version", ["1.0", "1.1", "1.3", "2.0", "2.1"])
def test_edited_logs_read_each_frame_as_python_can_reads_its_line(tmp_path, version):
    """A log's message lines edited at random (a character dropped, doubled or changed, a
    line cut or doubled, lines swapped): read or refused with an InputError, never a
    crash; every frame read is the one python-can's own code reads from its line."""
    import io

    from can.io.trc import TRCReader

    rng = np.random.default_rng(80 + int(version[0]) * 10 + int(version[2]))
    base = PEAK[version].splitlines()
    head = [i for i, x in enumerate(base) if x.startswith(";")]
    body = len(head)
    examples = int(os.environ.get("FUZZ_EXAMPLES", "40"))
    alphabet = "0123456789ABCDEFx.-; \tRxTDF"
    for _ in range(examples):
        lines = list(base)
        for _ in range(int(rng.integers(1, 5))):
            i = int(rng.integers(body, len(lines))) if len(lines) > body else body
            if i >= len(lines):
                break
            x = lines[i]
            what = int(rng.integers(5))
            j = int(rng.integers(0, max(len(x), 1)))
            if what == 0:
                lines[i] = x[:j] + x[j + 1 :]
            elif what == 1:
                lines[i] = x[:j] + alphabet[int(rng.integers(len(alphabet)))] + x[j + 1 :]
            elif what == 2:
                lines[i] = x[:j]
            elif what == 3:
                lines.insert(i, x)
            else:
                k = int(rng.integers(body, len(lines)))
                lines[i], lines[k] = lines[k], lines[i]
        text = "\n".join(lines) + "\n"
        try:
            got = trc.trc_frames(text.encode(), "bus.trc")
        except InputError:
            continue
        reader = TRCReader(io.StringIO(text))
        reader._extract_header()
        for k, row in enumerate(got.rows.tolist()):
            msg = _python_can_line(reader, lines[row - 1])
            assert msg is not None, (version, lines[row - 1])
            n = int(got.length[k])
            assert (msg.arbitration_id, msg.is_extended_id, bytes(msg.data)) == (
                int(got.ids[k]),
                bool(got.extended[k]),
                bytes(got.data[k, :n]),
            ), lines[row - 1]
            assert msg.timestamp == got.t_s[k]


@pytest.mark.parametrize(("end", "bom"), [("\r\n", ""), ("\r", ""), ("\r\n", "\ufeff")])
def test_crlf_and_cr_line_ends_and_a_byte_order_mark_read_as_the_plain_log(end, bom):
    """PEAK writes CR LF; a log of CR alone (a classic Mac's) reads as well, and one a
    Windows editor saved again as UTF-8 with a byte-order mark before its header."""
    for version in ("1.1", "2.1"):
        want = _frames(version)
        text = bom + PEAK[version].replace("\n", end)
        got = trc.trc_frames(text.encode(), "bus.trc")
        for name in ("t_s", "ids", "extended", "length", "data", "bus", "rows"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
        assert got.passed == want.passed


@pytest.mark.parametrize(
    ("version", "zone", "hours"),
    [
        ("1.1", "Europe/Berlin", 1.0),
        ("2.1", "Europe/Berlin", 2.0),
        ("2.1", "America/Detroit", -4.0),
    ],
)
def test_the_map_s_zone_puts_a_peak_start_on_utc(tmp_path, version, zone, hours):
    """PEAK's $STARTTIME is the logging computer's local clock: with the map's local_zone
    the frames move by the zone's offset on that date (Berlin: CET in March 2003, CEST in
    May 2014; Detroit: EDT), and the log is no longer marked a local clock; python-can's
    writer's start (UTC, as its header says) is kept."""
    path = tmp_path / "bus.trc"
    path.write_text(PEAK[version])
    plain = read_frames(path, path.name)
    zoned = read_frames(path, path.name, local_zone=zone)
    np.testing.assert_allclose(zoned.t_s - plain.t_s, -hours * 3600.0, rtol=0, atol=1e-6)
    assert plain.local_start and not zoned.local_start
    assert f"in {zone}, UTC{hours:+g} h) plus each frame's offset: Unix time" in zoned.clock
    written = _writer_log(tmp_path / "python_can.trc", "2.1", 10, seed=3)
    kept = read_frames(written, written.name, local_zone=zone)
    np.testing.assert_array_equal(kept.t_s, read_frames(written, written.name).t_s)
    assert not kept.local_start

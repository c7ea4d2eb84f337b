# ruff: noqa: E501 (CANOE holds the log lines as CANoe writes them)
"""A Vector ASC log's frames parsed at once (rwhonet.data.asc): python-can's reader's
messages, bit for bit, on logs its writer wrote, on the line forms CANoe writes (and
forms it does not), with absolute and relative stamps and any line ends, on every cut of
a log, across chunks, and on edited logs; and the logs left to python-can itself."""

from __future__ import annotations

import functools
import io
import logging
import tempfile
from pathlib import Path

import can
import numpy as np
import pytest
from can.io.asc import ASCReader
from can.util import CAN_FD_DLC
from hypothesis import given
from hypothesis import strategies as st

import rwhonet.data.asc as asc
from rwhonet.data.asc import AscError, asc_frames, encoding_of
from rwhonet.data.canlog import _asc, _python_can, _SummedStamps, read_frames
from rwhonet.errors import InputError
from support.canlog import asc_as_relative, assert_same_frames
from support.fuzz import fuzz_settings

# python-can warns of an FD frame whose length code and data length disagree: the fuzz
# writes many
logging.getLogger("can.io.asc").setLevel(logging.ERROR)

# The line forms of CANoe's and CANalyzer's ASC logging (the header, chip states,
# statistics, classic data frames with their trailing Length/BitCount/ID fields, remote
# frames with and without a length code, error frames with and without their details,
# CAN FD frames with and without a frame name, an FD remote frame, an FD error frame, a
# J1939 transport line), then forms no bus tool writes but a text log may hold: fewer
# bytes than the length code, a length code above 8, one-digit and three-digit bytes, a
# channel of two digits, a hex prefix, an identifier python-can's int() reads with an
# underscore, a lower-case direction and CANFD, stamps of 1 and 9 decimals, a channel
# and an identifier beyond 64 bits, a stamp of 25 characters.
CANOE = """\
date Fri Dec 04 09:12:44.512 am 2026
base hex  timestamps absolute
internal events logged
// version 17.3.91
// Measurement UUID: 1b2e8c0a-5d7f-4c1e-9a3b-0e6f2d8a4c71
Begin Triggerblock Fri Dec 04 09:12:44.512 am 2026
   0.000000 Start of measurement
   0.003117 CAN 1 Status:chip status error active
   0.003117 CAN 2 Status:chip status error active
   0.010204 1  1A0             Rx   d 8 0C 1F 0C 22 0C 0E 0C 13  Length = 231910 BitCount = 119 ID = 416
   0.010391 2  18FEF121x       Rx   d 8 FF 7D 20 4E FF FF FF FF  Length = 273910 BitCount = 141 ID = 419361057x
   0.011100 1  2B0             Tx   d 5 01 02 03 04 05  Length = 160000 BitCount = 83 ID = 688
   0.011150 1  2B0             TxRq d 5 01 02 03 04 05
   0.012000 1  3C1             Rx   r
   0.012500 1  3C2             Rx   r 4  Length = 80000 BitCount = 44 ID = 962
   0.013000 2  ErrorFrame
   0.013500 1  ErrorFrame ECC: 10100010
   0.014000 2  ErrorFrame Flags = 0xe CodeExt = 0x20a2 Code = 0x82 ID = 0 DLC = 0 Position = 5
   0.020000 CANFD   1 Rx        1a0  WheelSpeedsFD                   1 0 d 32 0c 1f 0c 22 0c 0e 0c 13 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00   130000  130 303000 b8000150 46500250 460a0250 20011736 20010205
   0.020400 CANFD   2 Tx        7ffx                                   0 1 8  8 01 02 03 04 05 06 07 08   105812  137   323000 d001b0b3 46500250 4b140250 20011736 2001040d
   0.020800 CANFD   1 Rx        2a0  Remote                          0 0 8  0   102187  133   323000 e000fb6c 46500250 4b140250 20011736 2001040d
   0.021000 CANFD   3 Tx ErrorFrame Not Acknowledge error, dominant error flag fffe c7 31ca
   1.003117 1  Statistic: D 412 R 0 XD 0 XR 0 E 3 O 0 B 12.40%
   1.010000 1  J1939TP FEF1p        6    0  0   -   Rx   d 9 A0 0F A6 60 3B D1 40 1F DE
   1.020204 1  1A0             Rx   d 8 0c 1f 0c 22 0c 0e 0c 13
   1.030204 1  1A0             Rx   d 3 0c 1f 0c 22 0c 0e 0c 13
   1.040204 1  1A0             Rx   d F 0c 1f 0c 22 0c 0e 0c 13 00
   1.050204 1  1A0             Rx   d 8 c 1 0c
   1.060204 11 0x1A0           Rx   d 2 0c 1f
   1.070204 1  1a0             rx   d 2 0c 1f
   1.080204 1  1A0             Rx   d 2 0x0c 1f
   1.090204 1  1A0             Rx   d 2 00c 1f
   1.100204 1  1_A0            Rx   d 2 0c 1f
   1.110204 canfd 1 Rx 1a0 1 0 8 8 00 00 00 00 00 00 00 00 x
   1.2 1  1A0 Rx d 2 0c 1f
   1.300000000 1 1A0 Rx d 1 ff
   1.400000 123456789012345678901 1A0 Rx d 1 01
   1.500000 1 123456789012345678901234 Rx d 1 02
   100000000.000000000000001 1  1A0             Rx   d 2 0c 1f
End TriggerBlock
"""


def _python_can_messages(path: Path, relative: bool) -> tuple[list[can.Message], Exception | None]:
    """What python-can's reader yields, as the pipeline opens it, and the error it stops
    with (None: none)."""
    got: list[can.Message] = []
    try:
        # can.LogReader(path) is ASCReader(path) for '.asc', in the locale's encoding; the
        # pipeline gives it the file opened in the encoding it reads the bytes in
        encoding = encoding_of(path.read_bytes())
        opened = _SummedStamps(path, encoding) if relative else open(path, encoding=encoding)
        with ASCReader(opened) as reader:
            got.extend(reader)
    except Exception as err:  # whatever its parsers raise
        return got, err
    return got, None


def _same_as_python_can(path: Path, relative: bool = False) -> int | None:
    """That the reader gives python-can's messages, or stops where python-can stops (the
    same exception, and the data frames it yielded before); the messages' count, -1 where
    both stop, None where the reader leaves the log to python-can."""
    try:
        with open(path, "rb") as f:  # as the pipeline reads it: a part at a time
            got = asc_frames(f, relative)
    except AscError as err:
        want, error = _python_can_messages(path, relative)
        assert error is not None, f"python-can read {len(want)} messages; ours: {err}"
        assert (type(err.cause), str(err.cause)) == (type(error), str(error))
        data = [m for m in want if not m.is_error_frame and not m.is_remote_frame]
        assert err.data_frames == len(data)
        return -1
    if got is None:
        return None
    want, error = _python_can_messages(path, relative)
    assert error is None, f"python-can stopped with {error!r}; ours read {got.t_s.size}"
    assert got.t_s.tolist() == [m.timestamp for m in want]
    assert got.ids.tolist() == [m.arbitration_id for m in want]
    assert got.extended.tolist() == [m.is_extended_id for m in want]
    assert got.error.tolist() == [m.is_error_frame for m in want]
    assert got.remote.tolist() == [m.is_remote_frame for m in want]
    assert got.channel.tolist() == [m.channel for m in want]
    data = [bytes(row[:n]) for row, n in zip(got.data, got.length, strict=True)]
    assert data == [bytes(m.data) for m in want]
    return len(want)


def _written(path: Path, n: int = 3000, seed: int = 0) -> Path:
    """python-can's writer's log of ``n`` messages: standard and extended data frames of
    0-8 bytes, CAN FD frames of every length, remote and error frames, on three channels."""
    rng = np.random.default_rng(seed)
    t = 1_700_000_000.0 + np.cumsum(rng.uniform(0.0, 0.002, n))
    with can.ASCWriter(path) as writer:
        for i in range(n):
            fd = bool(rng.random() < 0.2)
            size = int(rng.choice(CAN_FD_DLC)) if fd else int(rng.integers(0, 9))
            ext = bool(rng.random() < 0.3)
            kind = rng.random()
            msg = can.Message(
                timestamp=float(t[i]),
                arbitration_id=int(rng.integers(0, 2**29 if ext else 2**11)),
                is_extended_id=ext,
                is_fd=fd,
                bitrate_switch=bool(rng.random() < 0.5),
                data=bytes(rng.integers(0, 256, size).tolist()),
                channel=int(rng.integers(0, 3)),
            )
            if kind < 0.05 and not fd:
                msg.is_remote_frame, msg.data = True, bytearray()
            elif kind < 0.08:
                msg.is_error_frame = True
            writer.on_message_received(msg)
    return path


def test_python_can_s_writer_s_log_reads_as_python_can_reads_it(tmp_path):
    path = _written(tmp_path / "bus.asc")
    assert _same_as_python_can(path) == 3000
    # and the Frames the pipeline decodes: python-can's reader's, array for array
    ours, theirs = _asc(path, "bus.asc"), _python_can(path, "bus.asc", ".asc")
    assert ours is not None
    assert_same_frames(ours, theirs)
    assert "error frames" in ours.passed and "remote frames" in ours.passed


def test_the_same_log_of_relative_stamps_reads_as_python_can_reads_it(tmp_path):
    path = tmp_path / "bus.asc"
    path.write_text(asc_as_relative(_written(tmp_path / "abs.asc").read_text()))
    assert _same_as_python_can(path, relative=True) == 3000
    ours, theirs = _asc(path, "bus.asc"), _python_can(path, "bus.asc", ".asc")
    assert ours is not None and np.array_equal(ours.t_s, theirs.t_s)
    assert ours.clock == theirs.clock and "summed" in ours.clock


@pytest.mark.parametrize("line_end", ["\n", "\r\n", "\r"])
@pytest.mark.parametrize("relative", [False, True])
def test_canoe_s_line_forms_and_others_read_as_python_can_reads_them(tmp_path, line_end, relative):
    text = CANOE.replace("\n", line_end)
    if relative:  # sums below 2**53 ns (104 days), held exactly
        text = text.replace("   100000000.000000000000001", "   1000000.000000001")
        text = text.replace("timestamps absolute", "timestamps relative")
    path = tmp_path / "canoe.asc"
    path.write_bytes(text.encode())
    assert _same_as_python_can(path, relative) == 27
    # and the Frames decoded: python-can's path's (identifiers to 29 bits in both)
    ours, theirs = _asc(path, "canoe.asc"), _python_can(path, "canoe.asc", ".asc")
    assert ours is not None
    assert_same_frames(ours, theirs)


def test_the_forms_bus_tools_write_are_read_without_python_can_s_code(monkeypatch):
    """Speed, not exactness (python-can's code is exact for any line): every form CANoe
    writes (named and unnamed FD frames, TxRq, error frames with details, remote frames)
    is read at once; only the odd lines, and those python-can's pattern may match that
    are no frame (a statistic, a J1939 line), go through its code a line at a time."""
    lines = []
    one_line = asc._one_line
    monkeypatch.setattr(asc, "_one_line", lambda r, line: lines.append(line) or one_line(r, line))
    asc_frames(CANOE.encode(), False)
    stamps = [line.split()[0] for line in lines]
    assert stamps == [
        "1.003117",  # Statistic:
        "1.010000",  # J1939TP
        "1.060204",  # 0x1A0
        "1.080204",  # 0x0c
        "1.090204",  # 00c
        "1.100204",  # 1_A0
        "1.110204",  # canfd
        "1.400000",  # a channel of 21 digits
        "1.500000",  # an identifier of 24 digits
        "100000000.000000000000001",  # a stamp of 25 characters
    ]


def test_lines_python_can_s_code_raises_on_are_refused_with_the_frames_before(tmp_path):
    """A classic frame whose bytes run into its Length field (int('Length', 16)), an FD
    frame without its data: python-can stops there; so does the reader, and read_frames
    refuses the log naming python-can's error and the frames read before."""
    bad = {
        "classic": "   2.000000 1  1A0             Rx   d 8 0C 1F  Length = 231910\n",
        "fd": "   2.000000 CANFD   1 Rx        1a0  1 0 8  8\n",
    }
    for name, line in bad.items():
        path = tmp_path / f"{name}.asc"
        path.write_text(CANOE.replace("End TriggerBlock\n", line + "   3.0 1 1A0 Rx d 0\n"))
        assert _same_as_python_can(path) == -1
        with pytest.raises(InputError) as err:
            read_frames(path, path.name)
        (p,) = err.value.problems
        assert p.file == path.name and p.found.startswith("ValueError")
        assert "it failed after 20 frame(s)" in p.fix


def test_the_line_that_ends_the_header_is_taken_as_python_can_takes_it(tmp_path):
    """Without an 'internal events logged' line, python-can's header reading takes the
    first event line as the header's: the reader does the same (one frame fewer)."""
    path = tmp_path / "bus.asc"
    lines = _written(tmp_path / "w.asc", n=50).read_text().splitlines(keepends=True)
    body = [x for x in lines if "internal events" not in x and "Triggerblock" not in x]
    body = [x for x in body if "Start of measurement" not in x]
    path.write_text("".join(body))
    assert body[2].split()[1].isdigit()  # the first event follows the base line
    assert _same_as_python_can(path) == 49


@pytest.mark.parametrize("relative", [False, True])
def test_every_cut_of_a_log_reads_as_python_can_reads_it(tmp_path, relative):
    """A logger that lost power: the file cut at any byte gives python-can's messages (a
    cut line read as python-can reads it, or refused where it raises), its stamps absolute
    or relative."""
    text = CANOE
    if relative:
        text = text.replace("   100000000.000000000000001", "   1000000.000000001")
        text = text.replace("timestamps absolute", "timestamps relative")
    raw = text.encode()
    counts = [
        _same_as_python_can(_at(tmp_path, raw[:cut]), relative) for cut in range(len(raw) + 1)
    ]
    assert counts[-1] == 27 and len({c for c in counts if c and c > 0}) == 27
    assert -1 in counts  # some cuts leave a line python-can's code raises on


def _at(tmp_path: Path, raw: bytes) -> Path:
    path = tmp_path / "cut.asc"
    path.write_bytes(raw)
    return path


@pytest.mark.parametrize("end", ["\n", "\r\n", "\r"], ids=["LF", "CRLF", "CR"])
@pytest.mark.parametrize("relative", [False, True])
def test_chunks_of_a_few_lines_give_the_whole_log_s_messages(tmp_path, monkeypatch, relative, end):
    """The file is read a chunk of whole lines at a time (bounding the memory): chunks of
    one line and a few, the relative stamps summed across them, give the same messages,
    its lines ended as Unix, Windows or old Macs end them (a CR LF cut between two blocks
    read is one line end)."""
    path = _written(tmp_path / "abs.asc", n=400)
    text = path.read_text()
    if relative:
        text = asc_as_relative(text)
    path = tmp_path / "bus.asc"
    path.write_bytes(text.replace("\n", end).encode())
    whole = asc_frames(path.read_bytes(), relative)
    assert whole is not None and whole.t_s.size == 400
    for size in (1, 2, 59, 60, 61, 500):
        monkeypatch.setattr(asc, "CHUNK_BYTES", size)
        assert _same_as_python_can(path, relative) == 400
        with open(path, "rb") as f:
            part = asc_frames(f, relative)
        assert part is not None
        assert np.array_equal(part.t_s, whole.t_s) and np.array_equal(part.data, whole.data)


@pytest.mark.parametrize(
    "edit",
    [
        lambda t: t.replace("base hex", "base dec"),  # decimal identifiers and bytes
        lambda t: t.replace("base hex", "base HEX"),  # python-can refuses the base
        lambda t: t.replace("0.011100 1 ", "0.011100\x0b1 "),  # a vertical tab
    ],
    ids=["base dec", "base HEX", "vertical tab"],
)
def test_logs_the_reader_leaves_to_python_can_read_as_it_reads_them(tmp_path, edit):
    """What python-can's text reading sees otherwise than the reader's bytes (a control
    character) or reads otherwise (decimal), and a base it refuses: left to python-can,
    which read_frames then asks, as before the reader."""
    path = tmp_path / "bus.asc"
    path.write_bytes(edit(CANOE).encode())
    assert asc_frames(path.read_bytes(), False) is None
    assert _asc(path, "bus.asc") is None
    want, error = _python_can_messages(path, False)
    if error is not None:
        with pytest.raises(InputError):
            read_frames(path, "bus.asc")
        return
    frames = read_frames(path, "bus.asc")
    data = [m for m in want if not m.is_error_frame and not m.is_remote_frame]
    assert frames.t_s.tolist() == [m.timestamp for m in data]


@pytest.mark.parametrize("encoding", ["utf-8", "cp1252"])
def test_a_log_with_umlauts_reads_in_its_encoding(tmp_path, encoding):
    """CANoe on a German installation: 'Mär' in its date and trigger lines, umlauts in a
    comment and in FD frames' names, a frame indented with a no-break space, the file in
    UTF-8 or in Windows' cp1252 (which
    python-can, opening it in a UTF-8 locale, refused whole): the frames of the same log
    in ASCII, the lines with umlauts read by python-can's code in that encoding; with the
    map's local_zone, the date line puts them on UTC."""
    german = CANOE.replace("Fri Dec 04", "Fr Mär 05").replace("// version", "// Prüfstand")
    german = german.replace("WheelSpeedsFD  ", "Radgeschw_Ä_FD").replace("Remote  ", "Fern_Ö  ")
    # and a frame indented with a no-break space, which str.strip() takes for white space
    frame = "0.011120 1  2B1             Rx   d 1 05\n"
    german = german.replace("   0.011150 ", "\u00a0  " + frame + "   0.011150 ")
    plain = tmp_path / "plain.asc"
    text = CANOE.replace("Fri Dec 04", "Fr Mar 05")
    plain.write_text(text.replace("   0.011150 ", "   " + frame + "   0.011150 "), "ascii")
    path = tmp_path / "german.asc"
    path.write_bytes(german.encode(encoding))
    assert encoding_of(path.read_bytes()) == encoding
    with open(path, "rb") as f:
        assert encoding_of(f) == encoding
    assert _same_as_python_can(path) == 28
    assert_same_frames(read_frames(path, "log.asc"), read_frames(plain, "log.asc"))
    zoned = read_frames(path, "log.asc", "Europe/Berlin")
    assert zoned.t_s[0] == pytest.approx(1_772_698_364.512 + 0.010204, abs=1e-6)
    assert "2026-03-05T09:12:44.512000 in Europe/Berlin" in zoned.clock


@given(st.binary().map(lambda b: bytes(b"ab\r\n"[x % 4] for x in b)), st.integers(1, 9))
@fuzz_settings(200, 2_000)
def test_the_text_is_cut_after_line_ends_its_crlf_whole(raw, chunk):
    """A file read a block at a time is cut into chunks of whole lines, their line ends
    (CR LF, a lone CR) made line feeds: one after the other, the whole file's text so
    made; each chunk but the last ends a line, and a CR LF cut between blocks is one line
    end (two would add a blank line, which ends an ASC's header early)."""
    saved = asc.CHUNK_BYTES
    asc.CHUNK_BYTES = chunk
    try:
        parts = list(asc._text_parts(io.BytesIO(raw)))
    finally:
        asc.CHUNK_BYTES = saved
    assert b"".join(parts) == raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    assert all(p.endswith(b"\n") for p in parts[:-1]) and all(parts)


@pytest.mark.parametrize("scan", [1, 2, 3, 7])
@pytest.mark.parametrize(
    ("text", "encoding", "want"),
    [
        ("plain ASCII\n", "ascii", "utf-8"),
        ("Fr M\u00e4r 05 \u20ac \U0001f697\n", "utf-8", "utf-8"),
        ("Fr M\u00e4r 05 \u20ac Pr\u00fcfstand\n", "cp1252", "cp1252"),
        ("\u00e4\u00f6", "utf-8", "utf-8"),
    ],
)
def test_the_encoding_is_told_a_block_at_a_time(monkeypatch, scan, text, encoding, want):
    """The bytes are looked over a block at a time, a file's not held whole: a character
    of 2-4 bytes cut between blocks is read whole (UTF-8), a cp1252 byte that is no UTF-8
    anywhere in the file makes it cp1252, a file's last character cut short is no
    UTF-8."""
    monkeypatch.setattr(asc, "SCAN_BYTES", scan)
    raw = text.encode(encoding)
    assert encoding_of(raw) == encoding_of(io.BytesIO(raw)) == want
    if want == "utf-8" and not text[-1].isascii():  # its last character cut short
        cut = raw[:-1]
        assert encoding_of(cut) == encoding_of(io.BytesIO(cut)) != "utf-8"
    assert encoding_of(bytes([0x81, 0x8D])) == "latin-1"  # neither UTF-8 nor cp1252


_TOKENS = [
    " ", "\t", "\n", "\r\n", "\r", "\x0c", "x", ".", "0.5", " 8 ", " 64 ", " 0 ", "ErrorFrame", "CANFD",
    "canfd", "Rx", "rx", " d ", " r ", "-1", "+1", "0x", "_", "// c\n", "internal events logged\n",
    "date Fri Dec 04 09:12:44.512 am 2026\n", "1234567890123456789012345.5", " 1234567890 ",
    "\n 1.5 CANFD 1 Rx 1a0 1 0 8 8 ", "\n 1.5 1 12345678x Rx d 8 ", "1 0 d 64 ", " 99 ",
    "123456789012345678901234", "\n 2.5 123456789012345678901 1A0 Rx d 1 01\n",
    "\u00e4", "M\u00e4r", "\u00a0", " 1A0\u00a0Rx ", "\u2003", "\u0663",
]  # fmt: skip


@st.composite
def _edited(draw) -> bytes:
    """CANoe's forms or python-can's writer's lines with a few edits: a span deleted,
    characters or a field inserted, a line repeated."""
    text = draw(st.sampled_from([CANOE, _writer_s_lines()]))
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(text)))
        kind = draw(st.sampled_from(["drop", "chars", "token", "line"]))
        if kind == "drop":
            text = text[:at] + text[at + draw(st.integers(1, 20)) :]
        elif kind == "chars":
            text = (
                text[:at] + draw(st.text(" \t\nxdr0123456789abcdefABCDEF.", max_size=4)) + text[at:]
            )
        elif kind == "token":
            text = text[:at] + draw(st.sampled_from(_TOKENS)) + text[at:]
        else:
            lines = text.split("\n")
            lines.insert(draw(st.integers(0, len(lines))), draw(st.sampled_from(lines)))
            text = "\n".join(lines)
    return text.encode()


@functools.cache
def _writer_s_lines() -> str:
    """python-can's writer's log of 60 messages, as text."""
    with tempfile.TemporaryDirectory() as folder:
        return _written(Path(folder) / "w.asc", n=60, seed=1).read_text()


@given(_edited(), st.booleans(), st.sampled_from([asc.CHUNK_BYTES, 50, 300]))
@fuzz_settings(60, 10_000)
def test_an_edited_log_reads_as_python_can_reads_it_or_both_stop(
    tmp_path_factory, raw, relative, chunk
):
    """Whatever the edits, the reader gives python-can's messages or stops where it stops,
    whole or in small chunks, its stamps absolute or relative."""
    path = tmp_path_factory.mktemp("edited") / "bus.asc"
    path.write_bytes(raw)
    saved = asc.CHUNK_BYTES
    asc.CHUNK_BYTES = chunk
    try:
        _same_as_python_can(path, relative)
    finally:
        asc.CHUNK_BYTES = saved

"""The streaming reader: the ingest readers' header code, rows as they arrive, bad cells named."""

import io

import numpy as np
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.errors import InputError
from support.drives import CUPAC_MAP, column_map_params, write_columnmap
from support.serving import wavy_drive, write_drive


def collect(blocks):
    blocks = list(blocks)
    return blocks, {k: np.concatenate([b[k] for _, b in blocks]) for k in c.REQUIRED}


def test_blocks_hold_what_the_ingest_reader_reads(tmp_path):
    path = write_drive(tmp_path / "V-A.csv", duration_s=90)
    with open(path, "rb") as f:
        lay, blocks = read_rows(f, "V-A.csv", block_bytes=4096)
        blocks, cols = collect(blocks)
    assert len(blocks) > 5 and blocks[0][0] == 1
    assert [first for first, _ in blocks] == list(
        np.cumsum([0] + [len(b[c.T_S]) for _, b in blocks[:-1]]) + 1
    )
    ref = read_iovnbd(path)
    for k in c.REQUIRED:
        np.testing.assert_array_equal(cols[k], ref.columns[k])
    assert lay.names[c.OMEGA_RL] == " Wheel Speed Rear Left (rad/sec)"


def test_a_column_map_converts_units(tmp_path):
    df = wavy_drive(30)
    path = write_columnmap(df, tmp_path / "cupac.csv")
    cmap = {k: ColumnSpec(**v) for k, v in column_map_params(CUPAC_MAP).items()}
    with open(path, "rb") as f:
        _, blocks = read_rows(f, "cupac.csv", "cupac", cmap)
        _, cols = collect(blocks)
    np.testing.assert_allclose(cols[c.OMEGA_RL], df[c.OMEGA_RL], rtol=1e-12)
    np.testing.assert_allclose(cols[c.T_S], df[c.T_S], rtol=1e-12)


def test_missing_values_are_nan_and_bad_cells_are_named_with_their_row(tmp_path):
    path = write_drive(tmp_path / "V-A.csv", duration_s=10)
    lines = path.read_text().splitlines()
    cells = lines[5].split(",")
    cells[2] = ""  # latitude of data row 4 missing
    lines[5] = ",".join(cells)
    bad = lines[9].split(",")
    bad[12] = "oops"  # rear-left wheel speed of data row 9
    lines[9] = ",".join(bad)
    data = ("\n".join(lines) + "\n").encode()
    _, blocks = read_rows(io.BytesIO(data[: data.index(lines[9].encode())]), "x.csv")
    _, cols = collect(blocks)
    assert np.isnan(cols[c.LAT_DEG][4]) and np.isfinite(cols[c.LAT_DEG][[0, 1, 2, 3, 5]]).all()
    with pytest.raises(InputError) as err:
        collect(read_rows(io.BytesIO(data), "x.csv")[1])
    text = str(err.value)
    assert "x.csv, row 9, column ' Wheel Speed Rear Left (rad/sec)': expected a number" in text
    assert "'oops'" in text and "What to do" in text


def test_a_short_row_and_a_bad_header_are_refused(tmp_path):
    path = write_drive(tmp_path / "V-A.csv", duration_s=5)
    lines = path.read_text().splitlines()
    lines[3] = ",".join(lines[3].split(",")[:10])
    with pytest.raises(InputError, match="row 3.*29 comma-separated columns"):
        collect(read_rows(io.BytesIO(("\n".join(lines) + "\n").encode()), "x.csv")[1])
    with pytest.raises(InputError, match="Wheel Speed"):
        read_rows(io.BytesIO(b"a,b,c\n1,2,3\n"), "x.csv")
    with pytest.raises(InputError, match="at least one data row"):
        collect(read_rows(io.BytesIO(lines[0].encode() + b"\n"), "x.csv")[1])


def test_the_fix_screen_takes_out_the_fixes_validate_would_not_use():
    from rwhonet.data.incremental import FixScreen

    screen = FixScreen(min_sats=4)
    cols = {
        c.LAT_DEG: np.array([52.0, 0.0, 52.0, np.nan, 52.0]),
        c.LON_DEG: np.array([-1.0, 0.0, -1.0, np.nan, -1.0]),
        c.N_SATS: np.array([9.0, 0.0, 3.0, 0.0, np.nan]),
    }
    out = screen.screen(cols)
    assert np.isnan(out[c.LAT_DEG]).tolist() == [False, True, True, True, True]
    assert np.isnan(out[c.LON_DEG]).tolist() == [False, True, True, True, True]
    assert (screen.zeros, screen.low_sats) == (1, 2)  # the missing fix is not counted
    assert screen.note("V-A.csv") == (
        "V-A.csv: 3 row(s) taken as without a GNSS fix, as validate cuts them: 1 at latitude "
        "= longitude = 0 (what a receiver without a fix writes); 2 with fewer than "
        "validate.gnss.min_sats 4 satellites or no count"
    )
    assert FixScreen(4).note("V-A.csv") is None


def _screened(df, sizes, policy):
    from rwhonet.data.incremental import FixScreen

    screen = FixScreen(4, policy, 0.1)
    cols = {k: df[k].to_numpy(np.float64) for k in df.select_dtypes("number").columns}
    out, i = [], 0
    for n in sizes:
        out.append(screen.screen({k: v[i : i + n] for k, v in cols.items()}))
        i += n
    lat = np.concatenate([o[c.LAT_DEG] for o in out])
    return np.isnan(lat) & np.isfinite(cols[c.LAT_DEG]), screen


@pytest.mark.parametrize("sizes", [[1201], [7] * 172, [300, 1, 1, 899]])
def test_the_fix_screen_takes_out_jumps_and_a_frozen_receiver_as_validate_does(sizes):
    """validate's jump and frozen rules on a stream, whatever its blocking: a fix 500 m
    off for one row (it and the row back are jumps), a receiver that held one fix for 5 s
    while the car drove on (taken out once the wheels have turned 2 s under it), and a
    standstill whose identical fixes are right."""
    from rwhonet.config import load_params
    from rwhonet.data.quality import frozen_rows, implied_speed_m_s

    policy = load_params().validate.gnss
    df = wavy_drive(120)
    df.loc[300, c.LAT_DEG] += 500.0 / 111_000.0  # a jump, and back
    df.loc[600:649, [c.LAT_DEG, c.LON_DEG]] = df.loc[600, [c.LAT_DEG, c.LON_DEG]].to_numpy()
    df.loc[900:999, [c.OMEGA_FL, c.OMEGA_FR, c.OMEGA_RL, c.OMEGA_RR]] = 0.0  # stands 10 s,
    df.loc[900:999, [c.LAT_DEG, c.LON_DEG]] = df.loc[900, [c.LAT_DEG, c.LON_DEG]].to_numpy()
    out, screen = _screened(df, sizes, policy)
    t, lat, lon = (df[k].to_numpy() for k in (c.T_S, c.LAT_DEG, c.LON_DEG))
    jump = implied_speed_m_s(t, lat, lon) > policy.max_speed_m_s
    # the first fix after the held one (and after the 'standstill', whose wheels alone
    # stood) jumps too, as validate finds it
    assert np.flatnonzero(jump).tolist() == [300, 301, 650, 1000]
    wheel = 0.5 * (df[c.OMEGA_RL] + df[c.OMEGA_RR]).to_numpy()
    held = list(range(600, 650))  # validate: the whole run, from its first moving row
    assert np.flatnonzero(frozen_rows(lat, lon, wheel, 0.1, 2.0, 1.0)).tolist() == held
    # the stream: from the row where the wheels have turned 2 s under the held fix
    assert np.flatnonzero(out).tolist() == [300, 301, *range(619, 651), 1000]
    assert (screen.jumps, screen.frozen, screen.zeros, screen.low_sats) == (4, 31, 0, 0)
    note = screen.note("V-A.csv")
    assert "35 row(s) taken as without a GNSS fix" in note
    assert "4 implying more than validate.gnss.max_speed_m_s 70 m/s" in note
    assert "31 unchanged while the wheels turned for validate.gnss.frozen_min_s 2 s" in note


def test_predict_reads_the_satellite_count_where_the_layout_has_one(tmp_path):
    path = write_drive(tmp_path / "V-A.csv", duration_s=30)
    with open(path, "rb") as f:
        lay, blocks = read_rows(f, "V-A.csv")
        _, cols = collect(blocks)
    assert lay.names[c.N_SATS] == "Sats"


def test_a_pipe_is_read_as_its_file_is(tmp_path):
    """A pipe goes through the unbuffered path (select, a byte-wise header): same rows."""
    from support.pipes import piped

    path = write_drive(tmp_path / "V-A.csv", duration_s=40)
    with piped(path.read_bytes()) as f:
        lay, blocks = read_rows(f, "<stdin>", block_bytes=4096)
        _, cols = collect(blocks)
    with open(path, "rb") as f:
        ref_lay, ref_blocks = read_rows(f, "V-A.csv", block_bytes=4096)
        _, ref = collect(ref_blocks)
    assert lay.names == ref_lay.names
    for k in c.REQUIRED:
        np.testing.assert_array_equal(cols[k], ref[k])


WAITING_READER = """
import faulthandler, os, signal, sys, threading, time
from rwhonet.data.incremental import read_rows

faulthandler.dump_traceback_later(45, exit=True)  # a hang shows where every thread waits

class Stop(BaseException):
    pass

def handler(signum, frame):
    raise Stop

signal.signal(signal.SIGTERM, handler)
r, w = os.pipe()
os.write(w, open(sys.argv[1], "rb").read()[:20000])  # a header and some rows; w stays open

def other_thread_takes_the_signal():
    time.sleep(0.5)
    signal.pthread_kill(threading.get_ident(), signal.SIGTERM)

threading.Thread(target=other_thread_takes_the_signal).start()
try:
    for _ in read_rows(os.fdopen(r, "rb"), "<stdin>")[1]:
        pass
except Stop:
    print("stopped")
"""


def test_a_signal_another_thread_took_ends_a_read_waiting_on_a_pipe(tmp_path):
    """A process's SIGTERM can land on any thread (numpy's, ONNX Runtime's); Python runs the
    handler on the main thread, which a read() blocked on a paused pipe never reached: a live
    ``predict`` ignored SIGTERM until its next row came (CI, the signal test)."""
    import subprocess
    import sys

    path = write_drive(tmp_path / "V-A.csv", duration_s=40)
    done = subprocess.run(
        [sys.executable, "-c", WAITING_READER, str(path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.stdout.strip() == "stopped", done.stderr


def _piped(data: bytes, piece: int = 3001):
    """A pipe fed ``data`` in pieces from a thread: (reader file, writer thread)."""
    import os
    import threading

    r, w = os.pipe()

    def feed():
        with os.fdopen(w, "wb", buffering=0) as out:
            for i in range(0, len(data), piece):
                out.write(data[i : i + piece])

    writer = threading.Thread(target=feed)
    writer.start()
    return os.fdopen(r, "rb"), writer


@pytest.mark.parametrize("ending", [b"\r", b"\r\n"])
@pytest.mark.parametrize("source", ["file", "memory", "pipe"])
def test_classic_mac_and_windows_line_ends_read_as_lf(tmp_path, ending, source):
    """Excel's 'CSV (Macintosh)' ends lines in a lone CR: read as the LF file (it read as
    'no data rows' before), whether the header's CR comes with the rows or alone."""
    path = write_drive(tmp_path / "V-A.csv", duration_s=40)
    with open(path, "rb") as f:
        _, ref_blocks = read_rows(f, "V-A.csv", block_bytes=4096)
        _, ref = collect(ref_blocks)
    data = path.read_bytes().replace(b"\n", ending)
    assert b"\n" not in data or ending == b"\r\n"
    if source == "file":
        (tmp_path / "mac.csv").write_bytes(data)
        f, writer = open(tmp_path / "mac.csv", "rb"), None
    elif source == "memory":
        f, writer = io.BytesIO(data), None
    else:  # the header's CR and the byte after it arrive in separate writes
        f, writer = _piped(data, piece=data.index(b"\r") + 1)
    with f:
        _, blocks = read_rows(f, "mac.csv", block_bytes=4096)
        blocks, cols = collect(blocks)
    if writer is not None:
        writer.join()
    assert blocks[0][0] == 1
    for k in c.REQUIRED:
        np.testing.assert_array_equal(cols[k], ref[k])


def test_the_ingest_reader_reads_a_classic_mac_file_beyond_the_header_limit(tmp_path):
    """A lone-CR file longer than the header's 1 MB limit was refused as 'no line break'."""
    from rwhonet.data.csvio import HEADER_MAX_BYTES

    path = write_drive(tmp_path / "V-A.csv", duration_s=1200)
    data = path.read_bytes()
    assert len(data) > HEADER_MAX_BYTES
    mac = tmp_path / "V-mac.csv"
    mac.write_bytes(data.replace(b"\n", b"\r"))
    ref, got = read_iovnbd(path), read_iovnbd(mac)
    for k in c.REQUIRED:
        np.testing.assert_array_equal(got.columns[k], ref.columns[k])

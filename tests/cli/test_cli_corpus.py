"""No command ends in a traceback: every command that takes a drive, on every bad input.

``rwhonet recalibrate`` and ``rwhonet predict`` (``export`` takes no drive) run, in
this process through :func:`rwhonet.cli.main.main`, on every case of the 10 Hz
bad-input corpus (:mod:`support.corpus`, with the case's params as the project's
params.yaml), of the stream readers' corpus (:mod:`support.stream_corpus`, with
``--format`` and ``--signal-map`` / ``--nominal-radius`` as a user gives them), and
on a good drive moved to places across the Earth, and on random edits of a 10 Hz and a
stream drive (hypothesis: :mod:`support.fuzz`). Each must end with exit status
0, or 2 with the report (what was expected, what was found) on stderr; any other
exception fails the test (``main`` lets it through, where a user would see its
traceback). A refused ``predict`` leaves no output file behind, and ``predict`` writes
nothing on stdout (its seconds go to ``--output``; a C library's message would corrupt a
pipe's CSV). Through an outage,
``predict`` on the moved drive must give what it gives at home: the same distances,
errors and position error, and the same position and covariance up to the turn of
the local frame; and so must the drive as loggers write it (columns in another
order, stamps jittered off their slots, a time-of-day clock across midnight).

Slow (about a minute of CPU: 93 drives, two commands each, and ten predicts through an
outage); ``make test-fast`` skips it.
"""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from hypothesis import given

from rwhonet import paths
from rwhonet.cli.main import main
from rwhonet.config import ConfigError
from rwhonet.data import canonical as c
from rwhonet.geo import latlon_from_offsets_deg, offsets_m
from rwhonet.sim.streams import SIGNAL_MAP
from support.corpus import CASES, FILE, good_target, target_file, write_good_fleet
from support.drives import as_ddmm, as_hhmmss, make_params, write_iovnbd, write_params_yaml
from support.fuzz import corrupted_frames, edited_stream_drives, fuzz_settings
from support.serving import base_bundle, predict_args
from support.stream_corpus import CASES as STREAM_CASES
from support.stream_corpus import RADIUS_M, folder_of

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    return base_bundle(tmp_path_factory.mktemp("bundle"))


@pytest.fixture(autouse=True)
def own_store(store_uri, monkeypatch):
    monkeypatch.setenv("MLFLOW_TRACKING_URI", store_uri)


def run_both(bundle, drive: Path, extra: list[str], tmp_path: Path, capfd) -> dict[str, int]:
    """predict and recalibrate on one drive; check each ends well; return their statuses.

    ``rwhonet check`` runs on it too (since stop 74), ending in a report or its verdict:
    its checks are the ones recalibrate runs first, so recalibrate refuses whatever check
    refuses (check's status is not among those returned: recalibrate may refuse more, a
    drive too short to recalibrate on)."""
    out = tmp_path / "out.csv"
    commands = {
        "predict": predict_args(bundle, drive, out, "--quiet"),
        "recalibrate": [
            "recalibrate",
            "--base",
            str(bundle["model_onnx"].parent),
            "--drive",
            str(drive),
            "--seconds",
            "20",
            "--recipe",
            "radius+G",
        ],
        "check": ["check", "--drive", str(drive)],
    }
    codes = {}
    for name, argv in commands.items():
        capfd.readouterr()
        code = main(argv + extra)
        said = capfd.readouterr()
        assert code in (0, 2), f"{name}: exit {code}\n{said.err}"
        if code == 2:
            assert f"rwhonet {name}: error:" in said.err and "expected" in said.err, said.err
        elif name == "recalibrate":
            assert "registered whonet-R-target version" in said.out
        elif name == "check":
            assert said.out.rstrip().endswith("validate would accept it as target's drive")
        if name == "predict":  # its seconds go to --output; stdout holds nothing (no C
            # library's message either: capfd reads the file descriptor)
            assert said.out == "", said.out[:2000]
            assert out.exists() == (code == 0), said.err  # refused: nothing half-written
            assert not any(p.name.endswith(".partial") for p in tmp_path.iterdir())
            out.unlink(missing_ok=True)
        codes[name] = code
    checked = codes.pop("check")
    assert checked == 0 or codes["recalibrate"] == 2, "check refused what recalibrate took"
    return codes


def _format_of(case) -> str:
    """The target test drive's format under the case's params (iovnbd when they fail)."""
    try:
        params = make_params(Path("raw"), **case.overrides)
    except ConfigError:
        return "iovnbd"
    return params.data.roles["target_test"].format


@pytest.mark.parametrize("case", CASES, ids=[x.name for x in CASES])
def test_every_corpus_case_ends_in_a_report_or_success(case, bundle, tmp_path, monkeypatch, capfd):
    raw = tmp_path / "raw"
    write_good_fleet(raw)
    case.write(raw)
    overrides = {"data.source": "files", "data.root": str(raw), **case.overrides}
    monkeypatch.setattr(paths, "PARAMS", write_params_yaml(tmp_path / "params.yaml", **overrides))
    codes = run_both(bundle, target_file(raw), ["--format", _format_of(case)], tmp_path, capfd)
    stage = getattr(case.expect, "stage", None)
    if stage == "params" or (stage == "ingest" and case.expect.file == FILE):
        # refused by the same checks as the stages' (predict streams a file: no size limit)
        assert codes["recalibrate"] == 2
        assert codes["predict"] == (0 if case.name == "file_too_large" else 2)
    # what the pipeline takes, cut or not, the commands take too (but a cut by hand in
    # params' validate.cuts, which predict does not read: it refuses what was cut)
    if case.expect.kind == "accepted" or getattr(case.expect, "rule", "manual") != "manual":
        assert codes == {"predict": 0, "recalibrate": 0}


def _map_file(tmp_path: Path, with_time: bool) -> Path:
    signals = {
        k: {"column": col, "unit": unit}
        for k, (col, unit) in SIGNAL_MAP.items()
        if with_time or k != "t"
    }
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump(signals))
    return path


@pytest.mark.parametrize("case", STREAM_CASES, ids=[x.name for x in STREAM_CASES])
def test_every_stream_corpus_case_is_refused_with_a_report(case, bundle, tmp_path, capfd):
    root = tmp_path / "drive"
    root.mkdir()
    case.write(root)
    if case.fmt == "comma2k19":
        extra = ["--format", "comma2k19", "--nominal-radius", str(RADIUS_M)]
    else:
        fmt = "mdf4" if case.fmt == "mdf4" else "stream_csv"
        extra = ["--format", fmt, "--signal-map", str(_map_file(tmp_path, fmt == "stream_csv"))]
        extra += ["--nominal-radius", str(RADIUS_M)]
    codes = run_both(bundle, folder_of(case.fmt, root), extra, tmp_path, capfd)
    assert codes == {"predict": 2, "recalibrate": 2}


PLACES = {
    "San Francisco": (37.72, -122.47),
    "Sydney": (-33.87, 151.21),
    "Greenwich": (51.4779, -0.0005),
    "antimeridian": (-16.8, 179.9995),
    "near the North Pole": (89.9, 10.0),
    "near the South Pole": (-89.9, -70.0),
}


def _moved(place: str) -> pd.DataFrame:
    """The good drive moved to ``place`` with its local geometry kept (about its first fix)."""
    drive = good_target()
    lat, lon = drive[c.LAT_DEG].to_numpy(), drive[c.LON_DEG].to_numpy()
    east, north = offsets_m(lat[0], lon[0], lat, lon)
    new_lat, new_lon = latlon_from_offsets_deg(*PLACES[place], east, north)
    return drive.assign(**{c.LAT_DEG: new_lat, c.LON_DEG: new_lon})


@pytest.mark.parametrize("place", PLACES)
def test_a_relocated_drive_goes_through_both_commands(place, bundle, tmp_path, capfd):
    moved = _moved(place)
    assert np.ptp(moved[c.LON_DEG]) < 1.0 or place == "antimeridian" or "Pole" in place
    path = write_iovnbd(moved, tmp_path / "V-Moved.csv")
    codes = run_both(bundle, path, ["--nominal-radius", "0.294"], tmp_path, capfd)
    assert codes == {"predict": 0, "recalibrate": 0}


# The output's position is in the local frame of the last fix before the outage (east,
# north), which turns with the meridians: near a pole by about 5 degrees per km east. What
# a relocation must keep is everything else, and the position's range and covariance's
# invariants in that frame.
FRAME = ("east_m", "north_m", "lat_deg", "lon_deg", "cov_ee_m2", "cov_en_m2", "cov_nn_m2")
OUTAGE = "60:150"
OUTAGE_S = 90


def _predicted(bundle, drive: Path) -> pd.DataFrame:
    """``rwhonet predict`` through :data:`OUTAGE` on ``drive`` (its report on stderr)."""
    out = drive.with_suffix(".out.csv")
    assert main(predict_args(bundle, drive, out, "--quiet", "--outage", OUTAGE)) == 0
    return pd.read_csv(out)


@pytest.fixture(scope="module")
def at_home(bundle, tmp_path_factory):
    """``predict`` through an outage on the corpus's good drive where it was simulated."""
    return _predicted(
        bundle, write_iovnbd(good_target(), tmp_path_factory.mktemp("home") / "V-Home.csv")
    )


def _assert_same(got: pd.DataFrame, home: pd.DataFrame, but: tuple[str, ...] = ()) -> None:
    """The same rows and columns, every column but ``but`` equal to the CSV's 4 decimals."""
    assert list(got.columns) == list(home.columns) and len(got) == len(home)
    assert got["east_m"].notna().sum() == OUTAGE_S  # a position every second of the outage
    for col in home.columns:
        if col not in but:
            assert got[col].equals(home[col]) or np.allclose(
                got[col], home[col], rtol=0, atol=1e-3, equal_nan=True
            ), col


@pytest.mark.parametrize("place", PLACES)
def test_a_relocated_drive_predicts_the_same_distances_and_position_error(
    place, bundle, at_home, tmp_path
):
    got = _predicted(bundle, write_iovnbd(_moved(place), tmp_path / "V-Moved.csv"))
    home = at_home
    _assert_same(got, home, but=FRAME)  # distances, errors, CRSE, the position's error and radii
    # the range from the last fix and the covariance's axes: the frame's turn keeps them
    np.testing.assert_allclose(
        np.hypot(got["east_m"], got["north_m"]),
        np.hypot(home["east_m"], home["north_m"]),
        atol=1e-3,
    )
    np.testing.assert_allclose(_axes(got), _axes(home), atol=1e-3)  # the CSV's 4 decimals


def _columns_shuffled(path: Path) -> Path:
    """The CSV at ``path`` with its columns in another order (their text as written)."""
    frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    order = list(np.random.default_rng(0).permutation(frame.columns))
    assert order != list(frame.columns)
    frame[order].to_csv(path, index=False)
    return path


def _jittered(drive: pd.DataFrame) -> pd.DataFrame:
    """Stamps off their 10 Hz slots by up to 40 ms either way, as a logger's clock jitters."""
    jitter = np.random.default_rng(1).uniform(-0.04, 0.04, len(drive))
    return drive.assign(**{c.T_S: drive[c.T_S] + jitter})


def _busy_from_half_way(drive: pd.DataFrame) -> pd.DataFrame:
    """Stamps on their slots for half the drive, then off by a bell curve of 20 ms, to the
    ms (a logger that gets busy): rows nearest another's slot, stamps going back."""
    jitter = np.random.default_rng(3).normal(0.0, 0.02, len(drive))
    jitter[: len(drive) // 2] = 0.0
    t = np.round(drive[c.T_S].to_numpy() + jitter, 3)
    assert (np.diff(np.rint(t / 0.1)) <= 0).sum() >= 3
    return drive.assign(**{c.T_S: t})


def _across_midnight(drive: pd.DataFrame) -> pd.DataFrame:
    """A time-of-day clock that wraps to 0 s at midnight 75 s into the drive (mid-outage)."""
    t = drive[c.T_S] - drive[c.T_S].iloc[0] + 86400.0 - 75.0
    return drive.assign(**{c.T_S: np.round(t % 86400.0, 6)})


def _time_as_text(path: Path, form) -> Path:
    """The CSV at ``path`` with its time column's seconds written as text by ``form``."""
    frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    time = frame.columns[1]
    assert time.strip() == "Time"
    frame[time] = [form(float(t)) for t in frame[time]]
    frame.to_csv(path, index=False)
    return path


def _iso(t: float) -> str:
    """A time of day (s) on 2019-03-11 as ISO 8601 with the offset of UTC+05:30."""
    when = ISO_DAY + timedelta(milliseconds=round(t * 1000))
    return when.astimezone(timezone(timedelta(hours=5, minutes=30))).isoformat("T", "milliseconds")


def _clock(t: float) -> str:
    ms = round(t * 1000)
    return f"{ms // 3_600_000:02d}:{ms // 60_000 % 60:02d}:{ms % 60_000 / 1000:06.3f}"


def _nmea_fields(path: Path) -> Path:
    """The CSV at ``path`` with NMEA's fields as a receiver writes them and headers that say
    so: the time of day as hhmmss.ss, latitude and longitude as ddmm.mmmm (west negative)."""
    frame = pd.read_csv(path)
    renamed = {}
    for col in frame.columns:
        if col.strip() in ("Lat", "Long"):
            frame[col] = as_ddmm(frame[col])
            renamed[col] = f"{col} (ddmm.mmmm)"
        elif col.strip() == "Time":
            assert frame[col].max() < 86400.0
            frame[col] = as_hhmmss(frame[col], decimals=6)
            renamed[col] = f"{col} (hhmmss.ss)"
    assert len(renamed) == 3
    frame.rename(columns=renamed).to_csv(path, index=False)
    return path


ISO_DAY = datetime(2019, 3, 11, tzinfo=UTC)
LOGGER_HABITS = {
    "columns in another order": (lambda d: d, _columns_shuffled),
    "jittered stamps": (_jittered, lambda p: p),
    "a bell curve's jitter from half way": (_busy_from_half_way, lambda p: p),
    "a clock across midnight": (_across_midnight, lambda p: p),
    "jittered ISO 8601 text times": (_jittered, lambda p: _time_as_text(p, _iso)),
    "hh:mm:ss text across midnight": (_across_midnight, lambda p: _time_as_text(p, _clock)),
    "NMEA's hhmmss.ss and ddmm.mmmm across midnight": (_across_midnight, _nmea_fields),
}


@pytest.mark.parametrize("habit", LOGGER_HABITS)
def test_a_logger_s_habits_change_nothing_predict_gives_through_an_outage(
    habit, bundle, at_home, tmp_path
):
    change_drive, change_file = LOGGER_HABITS[habit]
    path = change_file(write_iovnbd(change_drive(good_target()), tmp_path / "V-Habit.csv"))
    got, home = _predicted(bundle, path), at_home
    if "midnight" in habit:  # one clock, unwrapped: the seconds follow on
        start, home_start = 86400.0 - 75.0, good_target()[c.T_S].iloc[0]
        np.testing.assert_allclose(got["t_s"] - start, home["t_s"] - home_start, atol=1e-6)
        assert got["t_s"].iloc[-1] > 86400.0
        got = got.assign(t_s=home["t_s"])
    if "ISO" in habit:  # seconds since 1970, UTC: the day's and the offset's taken out
        np.testing.assert_allclose(got["t_s"], home["t_s"] + ISO_DAY.timestamp(), atol=1e-3)
        got = got.assign(t_s=home["t_s"])
    _assert_same(got, home)


def _axes(frame: pd.DataFrame) -> np.ndarray:
    """The eigenvalues of each row's east/north covariance, m² (NaN where there is none)."""
    cov = frame[["cov_ee_m2", "cov_en_m2", "cov_en_m2", "cov_nn_m2"]].to_numpy(float)
    cov = cov.reshape(-1, 2, 2)
    out = np.full((len(frame), 2), np.nan)
    ok = np.isfinite(cov).all(axis=(1, 2))
    out[ok] = np.linalg.eigvalsh(cov[ok])
    return out


@pytest.mark.parametrize("fmt", ["comma2k19", "mdf4", "stream_csv"])
def test_a_good_drive_in_every_stream_format_goes_through_both_commands(
    fmt, bundle, tmp_path, capfd
):
    from support.stream_fleet import role_drive, tables_from_drive, write_drive

    radius = 0.294
    drive = write_drive(fmt, tables_from_drive(role_drive("target_test")), tmp_path, "C-B1", radius)
    extra = ["--format", fmt, "--nominal-radius", str(radius)]
    if fmt != "comma2k19":
        extra += ["--signal-map", str(_map_file(tmp_path, fmt == "stream_csv"))]
    assert run_both(bundle, drive, extra, tmp_path, capfd) == {"predict": 0, "recalibrate": 0}


# ------------------------------------------------------------------ random edits (hypothesis)
# The stages' fuzz tests (tests/data/bad/test_stage_fuzz.py, tests/data/test_stream_fuzz.py)
# check that ingest, validate and the stream readers end in a drive or a clear refusal
# whatever the edits. predict reads a 10 Hz drive by its own, incremental reader, so the same
# random edits (support.fuzz) go through both commands here. More: FUZZ_EXAMPLES=300.
FUZZ = fuzz_settings(8, deadline_ms=None)


@FUZZ
@given(df=corrupted_frames())
def test_a_corrupted_10hz_drive(df, bundle, tmp_path_factory, capfd):
    folder = tmp_path_factory.mktemp("drive")
    drive = write_iovnbd(df, folder / "C-X1.csv")
    run_both(bundle, drive, ["--nominal-radius", "0.294"], folder, capfd)


@FUZZ
@given(files=edited_stream_drives())
def test_an_edited_stream_drive(files, bundle, tmp_path_factory, capfd):
    folder = tmp_path_factory.mktemp("drive")
    streams = folder / "streams"
    streams.mkdir()
    for name, data in files.items():
        (streams / name).write_bytes(data)
    extra = ["--format", "stream_csv", "--signal-map", str(_map_file(folder, True))]
    run_both(bundle, streams, [*extra, "--nominal-radius", str(RADIUS_M)], folder, capfd)


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("edit", ["time_inf", "rear_wheels_inf_and_minus_inf"])
def test_a_non_finite_cell_gets_a_report_not_a_numpy_warning(edit, bundle, tmp_path, capfd):
    """Found by the fuzz tests with RuntimeWarnings as errors: predict printed numpy's
    "invalid value encountered in subtract" on stderr for a time cell inf (its first rows'
    steps, its time check) and the held-fix check for a rear wheel inf beside one -inf."""
    df = good_target(40.0)
    if edit == "time_inf":
        df.loc[:1, c.T_S] = np.inf
    else:
        df.loc[100, [c.OMEGA_RL, c.OMEGA_RR]] = [np.inf, -np.inf]
    drive = write_iovnbd(df, tmp_path / "C-X1.csv")
    run_both(bundle, drive, ["--nominal-radius", "0.294"], tmp_path, capfd)

"""Stream drives through the data stages: ingest reads every format, validate and label as ever.

Every role's drive is written as a logger would (CAN wheel speeds at 100 Hz with
jittered stamps, fixes at 10 Hz off the whole tenths) in one of the stream
formats: a comma2k19 folder, an MDF4 file through a signal map, a folder of
stream CSVs through a signal map. Ingest resamples each onto the grid and
records what it found; validate and label then run on it as on a 10 Hz file,
and give the 10 Hz drive's labels within ``LABEL_TOL_M``.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ConfigError
from rwhonet.data.canonical import WHEELS as WHEEL_KEYS
from rwhonet.errors import InputError
from rwhonet.stages.ingest import ingest
from rwhonet.stages.label import label
from rwhonet.stages.validate import validate
from support.drives import make_params, write_iovnbd
from support.stream_fleet import (
    FORMATS,
    ROLE_DRIVES,
    role_drive,
    stream_params,
    tables_from_drive,
    write_drive,
    write_stream_fleet,
)

# Per second, against the same drive as a native 10 Hz file: the resampling's own cost on a
# straight drive at constant speed (docs/readers.md measures it on curves and brakes).
LABEL_TOL_M = 2e-3


def _stages(params, work):
    manifest = ingest(params, work / "drives")
    report = validate(params, work / "drives", work / "segments", work / "validation.json")
    label(
        params,
        work / "segments",
        work / "samples",
        work / "calibration.json",
        work / "scaler.json",
    )
    samples = pd.concat(
        [
            pd.read_parquet(p).assign(drive=p.stem.split("__")[0])
            for p in sorted((work / "samples").glob("*.parquet"))
        ],
        ignore_index=True,
    )
    return manifest, report, samples


def _same_labels(native, samples: pd.DataFrame, atol_m: float) -> None:
    """The stream drives' labelled seconds are the 10 Hz drives' (``native``), within
    ``atol_m``, all but the few at a drive's ends."""
    _, _, native_samples = native
    merged = native_samples.merge(samples, on=["drive", "t_s"], suffixes=("_native", "_streams"))
    assert len(merged) >= len(samples) - 3 and len(merged) > 400
    for col in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(
            merged[f"{col}_streams"], merged[f"{col}_native"], rtol=0, atol=atol_m
        )


def _gnss_table(folder) -> pd.DataFrame:
    """A stream folder's gnss.csv under the canonical names (for an NMEA log of it)."""
    names = {"Time": "t_s", "Latitude": "lat_deg", "Longitude": "lon_deg", "NumSV": "n_sats"}
    return pd.read_csv(folder / "gnss.csv").rename(columns=names)


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    """The same drives as 10 Hz IO-VNBD files."""
    root = tmp_path_factory.mktemp("native")
    for role, (drive, *_) in ROLE_DRIVES.items():
        write_iovnbd(role_drive(role), root / "raw" / role / f"{drive}.csv")
    return _stages(make_params(root / "raw"), root)


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_stream_format_goes_through_ingest_validate_and_label(fmt, native, tmp_path):
    write_stream_fleet(tmp_path / "raw", fmt)
    manifest, report, samples = _stages(stream_params(tmp_path / "raw", fmt), tmp_path)
    by_drive = {d["drive"]: d for d in manifest["drives"]}
    assert set(by_drive) == {"V-S1", "C-A1", "C-B1"}
    b1 = by_drive["C-B1"]
    assert b1["header_match"] == "streams"
    streams = b1["streams"]
    assert streams["n_input_rows"] == sum(s["rows"] for s in streams["streams"])
    assert streams["glitch_rows"] == [] and streams["n_glitch_samples"] == 0
    assert {round(1 / s["median_step_s"]) for s in streams["streams"]} == {100, 10}
    if fmt == "comma2k19_route":  # 150 s in one-minute segments 0, 1, 2: one drive
        said = " ".join(b1["notes"])
        assert "a comma2k19 route of 3 segment(s) (0-2), read as one drive" in said
        assert "CAN/wheel_speed of 3 segments joined in time order" in said
    assert report["totals"]["segments"] == 3
    _, native_report, _ = native
    # Fixes at a 30 ms phase: the grid starts and ends inside the 10 Hz drive's span, so
    # the stream drive keeps its seconds but its first (a start fix) and last.
    assert report["totals"]["seconds_kept"] >= native_report["totals"]["seconds_kept"] - 6
    if fmt == "mdf4":  # an MDF4 file's clock starts at its measurement (the drive's 45000 s)
        samples = samples.assign(t_s=samples["t_s"] + 45000.0)
    _same_labels(native, samples, LABEL_TOL_M)


@pytest.mark.parametrize("stamped", [False, True])
def test_a_receiver_s_nmea_log_in_place_of_gnss_csv_goes_through_the_stages(
    stamped, native, tmp_path
):
    """Every drive's fixes as the receiver's NMEA log (GGA and RMC, the UTC time of day
    the wheels' clock counts in; or each line after the logger's stamp) beside wheels.csv:
    ingest, validate and label give the 10 Hz drives' labels, within the log's
    ddmm.mmmmmm rounding (under 1 mm a coordinate), and the manifest says where the fixes
    came from."""
    from support.nmea import nmea_lines, write_nmea

    paths_ = write_stream_fleet(tmp_path / "raw", "stream_csv")
    for folder in paths_.values():
        gnss = _gnss_table(folder)
        t = gnss["t_s"].to_numpy()
        lines = nmea_lines(gnss, 1_552_262_400.0 + t, stamps=t if stamped else None)
        write_nmea(folder / "gps.nmea", lines)
        (folder / "gnss.csv").unlink()
    manifest, report, samples = _stages(stream_params(tmp_path / "raw", "stream_csv"), tmp_path)
    b1 = {d["drive"]: d for d in manifest["drives"]}["C-B1"]
    said = " ".join(b1["notes"])
    assert "an NMEA log: 1500 epochs (1500 GGA, 1500 RMC sentences), 1500 with a fix" in said
    assert ("logger stamp" in said) == stamped
    assert ("read as UTC seconds of the day" in said) != stamped
    assert report["totals"]["segments"] == 3
    _same_labels(native, samples, 2 * LABEL_TOL_M)


@pytest.mark.parametrize("receiver", ["nmea", "ubx"])
def test_a_candump_log_beside_the_receiver_s_log_goes_through_the_stages(
    native, tmp_path, receiver
):
    """Every drive as a Linux logger writes it: the wheel speeds as raw CAN frames in
    can0.log (candump -l, on the fleet's seconds of the day), the fixes as the receiver's
    unstamped NMEA log, or its u-blox NAV-PVT messages kept gzipped (gps.ubx.gz); a
    stream_csv map naming the DBC (under data.root) and its signals. Ingest, validate and
    label give the 10 Hz drives' labels within the DBC's 0.01 km/h and the log's rounding
    (NAV-PVT's 1e-7 degrees, truncated by the writer: 1.1 cm a coordinate), and the
    manifest says what was decoded."""
    import gzip

    from rwhonet.sim.streams import StreamTables
    from support.canlog import DBC, stream_frames, write_candump
    from support.nmea import nmea_lines, write_nmea
    from support.ubx import pvt_log

    root = tmp_path / "raw"
    paths_ = write_stream_fleet(root, "stream_csv")
    for role, folder in paths_.items():
        wheels = pd.read_csv(folder / "wheels.csv").rename(
            columns={"Time": "t_s"} | {f"WheelSpeed_{w[6:8].upper()}": w for w in WHEEL_KEYS}
        )
        gnss = _gnss_table(folder)
        frames = stream_frames(StreamTables(wheels, gnss.iloc[:0]), ROLE_DRIVES[role][1])
        write_candump(*frames, folder / "can0.log")
        utc = 1_552_262_400.0 + gnss["t_s"].to_numpy()
        if receiver == "nmea":
            write_nmea(folder / "gps.nmea", nmea_lines(gnss, utc))
        else:
            (folder / "gps.ubx.gz").write_bytes(gzip.compress(pvt_log(gnss, utc)))
        (folder / "wheels.csv").unlink()
        (folder / "gnss.csv").unlink()
    (root / "bus.dbc").write_text(DBC)
    signals = {"t": {"column": "Time", "unit": "s"}} | {
        f"omega_{w}": {"column": f"WhlSpd_{w.upper()}", "unit": "km/h"}
        for w in ("fl", "fr", "rl", "rr")
    }
    bus_map = {
        "logger_csv": {"reader": "stream_csv", "signals": signals, "dbc": str(root / "bus.dbc")}
    }
    params = stream_params(root, "stream_csv", **{"data.signal_maps": bus_map})
    manifest, report, samples = _stages(params, tmp_path)
    b1 = {d["drive"]: d for d in manifest["drives"]}["C-B1"]
    said = " ".join(b1["notes"])
    assert "can0.log: raw CAN frames decoded with bus.dbc: 1 of the log's 1 frame IDs" in said
    assert "read as UTC seconds of the day" in said
    if receiver == "ubx":
        assert "gps.ubx.gz: a UBX log: 1500 epochs (NAV-PVT), 1500 with a fix" in said
    assert report["totals"]["segments"] == 3
    _same_labels(native, samples, 2 * LABEL_TOL_M if receiver == "nmea" else 0.02)


def test_a_stream_glitch_is_cut_and_reported_with_its_stream_row(tmp_path):
    """One CAN sample at ten times its wheel's speed: that second is cut, named by its row."""
    root = tmp_path / "raw"
    write_stream_fleet(root, "stream_csv")
    drive = role_drive("target_test")
    tables = tables_from_drive(drive)
    wheels = tables.wheels.copy()
    k = int(np.searchsorted(wheels["t_s"].to_numpy(), 45060.53))
    wheels.loc[k, "omega_rl_rad_s"] *= 10.0
    write_drive("stream_csv", type(tables)(wheels, tables.gnss), root / "target_test", "C-B1", 0)
    params = stream_params(root, "stream_csv")
    ingest(params, tmp_path / "drives")
    report = validate(params, tmp_path / "drives", tmp_path / "seg", tmp_path / "v.json")
    b1 = next(d for d in report["drives"] if d["drive"] == "C-B1")
    cuts = [(x["start_s"], x["end_s"], x["rule"]) for x in b1["cuts"]]
    assert (45060.0, 45061.0, "wheel_glitch") in cuts
    listed = b1["wheel_glitches"]["listed"]
    assert listed[0]["row"] == k + 1  # the 1-based sample (data row) of wheels.csv
    assert "target_test/C-B1/wheels.csv" in listed[0]["stream"]
    assert listed[0]["channel"] == "WheelSpeed_RL"
    assert json.loads((tmp_path / "v.json").read_text())["drives"] == report["drives"]


def test_a_folder_format_finds_folders_and_refuses_a_file(tmp_path):
    root = tmp_path / "raw"
    paths_ = write_stream_fleet(root, "comma2k19", duration_s=40.0)
    (paths_["target_test"].parent / "notes.txt").write_text("not a drive")  # a file: ignored
    manifest = ingest(stream_params(root, "comma2k19"), tmp_path / "drives")
    assert [d["drive"] for d in manifest["drives"]] == ["V-S1", "C-A1", "C-B1"]
    assert manifest["drives"][0]["source_file"].endswith("source_train/V-S1")


def test_a_signal_map_that_does_not_fit_its_reader_is_refused(tmp_path):
    root = tmp_path / "raw"
    write_stream_fleet(root, "stream_csv", duration_s=40.0)
    params = stream_params(root, "stream_csv")
    bad = {
        "reader": "stream_csv",
        "signals": {k: v for k, v in params.data.signal_maps["logger_csv"].signals.items()},
    }
    bad["signals"] = {k: {"column": v.column, "unit": v.unit} for k, v in bad["signals"].items()}
    del bad["signals"]["t"]
    with pytest.raises(ConfigError, match="data.signal_maps.logger_csv.signals.t: missing"):
        ingest(
            stream_params(root, "stream_csv", **{"data.signal_maps": {"logger_csv": bad}}),
            tmp_path / "drives",
        )


def test_a_linear_wheel_speed_needs_the_vehicle_radius_and_a_bad_folder_says_where(tmp_path):
    root = tmp_path / "raw"
    paths_ = write_stream_fleet(root, "comma2k19", duration_s=40.0)
    (paths_["target_test"] / "processed_log" / "CAN" / "wheel_speed" / "value").write_bytes(b"x")
    with pytest.raises(InputError) as err:
        ingest(stream_params(root, "comma2k19"), tmp_path / "drives")
    (p,) = err.value.problems
    assert p.file.endswith("target_test/C-B1/CAN/wheel_speed/value")
    assert "NumPy array" in p.expected and p.fix


def test_a_stream_split_across_files_goes_through_the_stages_naming_each_file_s_rows(tmp_path):
    """The glitch drive's wheels.csv as a logger rotating its files writes it (wheels_1.csv,
    wheels_2.csv.gz, the glitch in the second): the same seconds are cut, and validate lists
    the glitch by the second file and its own row."""
    import gzip

    root = tmp_path / "raw"
    write_stream_fleet(root, "stream_csv")
    tables = tables_from_drive(role_drive("target_test"))
    wheels = tables.wheels.copy()
    k = int(np.searchsorted(wheels["t_s"].to_numpy(), 45060.53))
    wheels.loc[k, "omega_rl_rad_s"] *= 10.0
    folder = write_drive(
        "stream_csv", type(tables)(wheels, tables.gnss), root / "target_test", "C-B1", 0
    )
    header, *rows = (folder / "wheels.csv").read_text().splitlines()
    cut = k - 1000
    (folder / "wheels_1.csv").write_text("\n".join([header, *rows[:cut]]) + "\n")
    second = "\n".join([header, *rows[cut:]]) + "\n"
    (folder / "wheels_2.csv.gz").write_bytes(gzip.compress(second.encode()))
    (folder / "wheels.csv").unlink()
    params = stream_params(root, "stream_csv")
    ingest(params, tmp_path / "drives")
    report = validate(params, tmp_path / "drives", tmp_path / "seg", tmp_path / "v.json")
    b1 = next(d for d in report["drives"] if d["drive"] == "C-B1")
    assert (45060.0, 45061.0, "wheel_glitch") in [
        (x["start_s"], x["end_s"], x["rule"]) for x in b1["cuts"]
    ]
    listed = b1["wheel_glitches"]["listed"][0]
    assert listed["row"] == k + 1 - cut  # the data row of wheels_2.csv.gz
    assert "target_test/C-B1/wheels_2.csv.gz [" in listed["stream"]
    assert listed["channel"] == "WheelSpeed_RL"


# IO-VNBD's columns (rwhonet.data.iovnbd.LAYOUT) as a stream folder's signal map: the
# headers matched as any CSV's (case, spaces and the unit suffix aside)
IOVNBD_SIGNALS = {
    "t": ("Time", "s"),
    "lat": ("Lat", "deg"),
    "lon": ("Long", "deg"),
    "n_sats": ("Sats", "count"),
    "omega_fl": ("Wheel Speed Front Left", "rad/s"),
    "omega_fr": ("Wheel Speed Front Right", "rad/s"),
    "omega_rl": ("Wheel Speed Rear Left", "rad/s"),
    "omega_rr": ("Wheel Speed Rear Right", "rad/s"),
}


def test_a_10_hz_logger_s_rotated_files_go_through_the_stages_as_one_drive(native, tmp_path):
    """A 10 Hz logger that rotates its file (``C-B1_000.csv``, ``C-B1_001.csv``, ...): each
    file would be a drive of its own, too short for a long outage. Its files in one folder,
    read through a signal map of the same columns (``reader: stream_csv``), are joined in
    time order and go through the stages as the one drive: the labels of the IO-VNBD file
    within the resampler's cost (its first and last 0.3 s are no grid rows)."""
    root = tmp_path / "raw"
    for role, (drive, *_) in ROLE_DRIVES.items():
        one = write_iovnbd(role_drive(role), tmp_path / "one" / f"{drive}.csv")
        header, *rows = one.read_text().splitlines()
        bounds = [0, 517, 1003, len(rows)]
        folder = root / role / drive
        folder.mkdir(parents=True)
        for k in (2, 0, 1):  # written in no order
            part = rows[bounds[k] : bounds[k + 1]]
            (folder / f"{drive}_{k:03d}.csv").write_text("\n".join([header, *part]) + "\n")
    signals = {k: {"column": col, "unit": unit} for k, (col, unit) in IOVNBD_SIGNALS.items()}
    roles = stream_params(root, "stream_csv").data.roles
    params = make_params(
        root,
        **{
            "data.roles": {
                r: {"glob": s.glob, "format": "rotated", "vehicle": s.vehicle, "required": True}
                for r, s in roles.items()
            },
            "data.signal_maps": {"rotated": {"reader": "stream_csv", "signals": signals}},
        },
    )
    manifest, report, samples = _stages(params, tmp_path)
    b1 = next(d for d in manifest["drives"] if d["drive"] == "C-B1")
    assert "C-B1_000.csv + " in " ".join(b1["notes"])
    assert "one stream split across 3 files, joined in time order" in " ".join(b1["notes"])
    assert report["totals"]["segments"] == 3
    _same_labels(native, samples, LABEL_TOL_M)

"""``rwhonet check``: a drive read and checked as ingest and validate would, before a run."""

import json

import pytest

from rwhonet.cli.main import main
from rwhonet.data import canonical as c
from support.corpus import TARGET_RADIUS_M, weaving_drive
from support.drives import write_iovnbd

CAR = ["--nominal-radius", str(TARGET_RADIUS_M)]


def _turns():
    """A drive through tight turns (8 m/s, ±0.6 rad/s), its wheels where they belong."""
    return weaving_drive(150.0, 8.0, 0.6, track_m=1.5, wheelbase_m=2.7)


def test_a_good_drive_passes_and_every_check_says_what_it_told(tmp_path, capsys):
    drive = write_iovnbd(_turns(), tmp_path / "V-Turns.csv")
    assert main(["check", "--drive", str(drive), *CAR]) == 0
    out = capsys.readouterr().out.splitlines()
    assert (
        out[0]
        == f"{drive}: 1501 rows, 151 s; 150 s valid in 1 segment(s) (cut: partial_second 1 s)"
    )
    assert out[1].startswith("  tyre radius: 0.29") and "the wheel speeds' unit fits" in out[1]
    assert out[2].startswith("  yaw rate: turns as the GNSS course turns (gain 0.999 ± ")
    assert out[3].startswith("  left and right wheels: in their columns (rear gain ")
    assert out[4].startswith("  front and rear wheels: in their columns (gain ")
    assert out[-1] == f"{drive}: validate would accept it as target's drive"
    assert main(["check", "--drive", str(drive), *CAR, "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["seconds_kept"] == 150 and record["segments"] == 1
    assert record["wheel_axles"]["checked"] and record["wheel_axles"]["tight_turns"] >= 10
    assert record["columns"][c.OMEGA_FL] == " Wheel Speed Front Left (rad/sec)"


def test_a_check_that_cannot_tell_says_why(tmp_path, capsys):
    """Every wheel at the car's speed and wide turns: the sides and axles are not told, and
    the lines say so (a mapping mistake they could not see is not ruled out)."""
    drive = write_iovnbd(weaving_drive(150.0), tmp_path / "V-Wide.csv")
    assert main(["check", "--drive", str(drive), *CAR]) == 0
    out = capsys.readouterr().out
    assert "  left and right wheels: not told: the rear wheels never differed" in out
    assert "  front and rear wheels: not told: the front and rear wheels never differed" in out


def test_a_drive_validate_would_refuse_exits_2_with_its_report(tmp_path, capsys):
    df = _turns()
    front, rear = [c.OMEGA_FL, c.OMEGA_FR], [c.OMEGA_RL, c.OMEGA_RR]
    df[front + rear] = df[rear + front].to_numpy()
    drive = write_iovnbd(df, tmp_path / "V-Axles.csv")
    assert main(["check", "--drive", str(drive), *CAR]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "rwhonet check: error:" in captured.err and str(drive) in captured.err
    assert (
        "Wheel Speed Front Left (rad/sec) /  Wheel Speed Front Right (rad/sec) / " in captured.err
    )
    assert "the front and rear columns look exchanged" in captured.err


def test_the_real_minute_is_accepted_and_its_untold_checks_named(capsys):
    from support.realminute import REAL, real_minute

    real_minute()  # skipped where the segment is not on this machine
    args = ["check", "--drive", str(REAL), "--format", "comma2k19", "--nominal-radius", "0.362"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert ": 597 rows, 61 s; 59 s valid in 1 segment(s) (cut: partial_second 2 s)" in out
    # what the reader did: the fixes placed at their receiver epochs, their lag estimated
    assert "  note: " in out and "fixes placed at their receiver epochs" in out
    assert "earlier than stamped" in out and "stamps kept" in out
    assert "  yaw rate: not told: turned too little to tell (gain 0.972" in out
    assert "  front and rear wheels: not told: only 0 pairs of seconds in a tight turn" in out


@pytest.mark.parametrize("bad", [["--drive", "nowhere.csv"], ["--drive", "x", "--format", "nope"]])
def test_a_drive_that_cannot_be_read_is_a_clear_error(bad, capsys):
    assert main(["check", *bad]) == 2
    err = capsys.readouterr().err
    assert "rwhonet check: error:" in err and "Traceback" not in err


def test_several_drives_each_get_a_verdict_and_the_refused_ones_one_report(tmp_path, capsys):
    good = write_iovnbd(_turns(), tmp_path / "V-Turns.csv")
    df = _turns()
    df[[c.OMEGA_RL, c.OMEGA_RR]] = df[[c.OMEGA_RR, c.OMEGA_RL]].to_numpy()
    sides = write_iovnbd(df, tmp_path / "V-Sides.csv")
    argv = ["check", "--drive", str(sides), str(good), str(tmp_path / "V-None.csv"), *CAR]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out.count("validate would accept it") == 1 and str(good) in captured.out
    assert f"in 2 of 3 drives ({sides}, {tmp_path / 'V-None.csv'})" in captured.err
    assert "look exchanged (left for right)" in captured.err and "no such file" in captured.err
    assert main([*argv[:2], str(good), str(good), *CAR, "--json"]) == 0
    assert [r["file"] for r in json.loads(capsys.readouterr().out)] == [str(good)] * 2


def test_json_of_a_refused_drive_and_an_unknown_car_are_clear_errors(tmp_path, capsys):
    """Found reviewing: --json with its one drive refused ended in an IndexError; a car
    params.yaml does not know named the simulator's profile and not what to give."""
    assert main(["check", "--drive", str(tmp_path / "V-None.csv"), "--json"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "no such file" in captured.err
    drive = write_iovnbd(_turns(), tmp_path / "V-Turns.csv")
    assert main(["check", "--drive", str(drive), "--vehicle", "van"]) == 2
    err = capsys.readouterr().err
    assert "--vehicle van: not a car params.yaml knows" in err and "--nominal-radius" in err
    assert main(["check", "--drive", str(drive), "--vehicle", "van", *CAR]) == 0
    assert capsys.readouterr().out.endswith("validate would accept it as van's drive\n")


def test_a_canedge_log_the_logger_packed_is_refused_saying_how_to_unpack_it(tmp_path, capsys):
    """A CANedge set to compress (``.MFC``) or encrypt (``.MFE``, ``.MFM``) its MDF4 log
    files, which asammdf cannot open: in a stream folder beside the receiver's log (where
    it was left out, and the drive then refused for wheels it did not find) and given
    alone as an ``mdf4`` drive (refused as an unreadable MDF4), each is refused naming
    the file, how it was packed and the maker's converter, exit 2."""
    from rwhonet.sim.streams import StreamTables
    from support.canlog import DBC, stream_frames, write_mdf_bus_log
    from support.nmea import nmea_lines
    from support.stream_corpus import RADIUS_M, good_tables

    day = 1_552_262_400.0
    good = good_tables()
    stamps, ids, data = stream_frames(StreamTables(good.wheels, good.gnss.iloc[:0]), RADIUS_M, day)
    folder = tmp_path / "LOG"
    folder.mkdir()
    half = stamps.size // 2
    write_mdf_bus_log(stamps[:half], ids[:half], data[:half], folder / "00000001.MF4")
    write_mdf_bus_log(stamps[half:], ids[half:], data[half:], folder / "00000002.MF4")
    (folder / "00000002.MF4").rename(folder / "00000002.MFC")  # as the logger names it
    (folder / "gps.nmea").write_text("\r\n".join(nmea_lines(good.gnss, day + good.gnss["t_s"])))
    (tmp_path / "v.dbc").write_text(DBC)
    wheels = [
        f"  omega_{w}: {{column: WhlSpd_{w.upper()}, unit: km/h}}" for w in ("fl", "fr", "rl", "rr")
    ]
    smap = tmp_path / "bus.yaml"
    smap.write_text("dbc: v.dbc\nsignals:\n  t: {column: t, unit: s}\n" + "\n".join(wheels) + "\n")
    car = ["--nominal-radius", str(RADIUS_M)]
    fmt = ["--format", "stream_csv", "--signal-map", str(smap)]
    assert main(["check", "--drive", str(folder), *fmt, *car]) == 2
    said = capsys.readouterr().err
    assert "00000002.MFC: expected an MDF4 log as asammdf reads it (.MF4)" in said
    assert "found a CANedge log file the logger compressed (.MFC)" in said
    assert "CSS Electronics' MDF converter (mdf2finalized" in said
    (folder / "00000002.MFC").rename(tmp_path / "00000002.MFE")
    one = ["--format", "mdf4", "--signal-map", str(smap.with_name("one.yaml"))]
    fixes = ["  lat: {column: Latitude, unit: deg}", "  lon: {column: Longitude, unit: deg}"]
    smap.with_name("one.yaml").write_text("dbc: v.dbc\nsignals:\n" + "\n".join(wheels + fixes))
    assert main(["check", "--drive", str(tmp_path / "00000002.MFE"), *one, *car]) == 2
    said = capsys.readouterr().err
    assert "found a CANedge log file the logger encrypted (.MFE)" in said
    assert "the device's passwords.json" in said


@pytest.mark.parametrize("bound", [None, 5.0])
def test_a_drive_whose_receiver_states_its_accuracy_shows_it(tmp_path, capsys, monkeypatch, bound):
    """A column map's h_acc (cm): check gives the stated accuracy's median, 95th
    percentile and largest value, and what validate.gnss.max_h_acc_m does with it; with a
    bound of 5 m the seconds stated at 12 m are cut as low_sats."""
    from rwhonet import paths
    from support.drives import CUPAC_MAP, column_map_params, write_columnmap, write_params_yaml

    df = _turns()
    df[c.H_ACC_M] = 1.2
    t = df[c.T_S].to_numpy() - df[c.T_S].iloc[0]
    df.loc[(t > 50.0) & (t < 53.0), c.H_ACC_M] = 12.0
    cmap = CUPAC_MAP | {"h_acc": ("HAcc", "cm")}
    drive = write_columnmap(df, tmp_path / "V-Acc.csv", cmap)
    overrides = {"data.column_maps.acc": column_map_params(cmap)}
    if bound is not None:
        overrides["validate.gnss.max_h_acc_m"] = bound
    monkeypatch.setattr(paths, "PARAMS", write_params_yaml(tmp_path / "params.yaml", **overrides))
    assert main(["check", "--drive", str(drive), "--format", "acc", *CAR]) == 0
    out = capsys.readouterr().out.splitlines()
    (line,) = [x for x in out if x.startswith("  stated horizontal accuracy: ")]
    assert line.startswith(
        "  stated horizontal accuracy: median 1.2 m, 95th percentile 1.2 m, largest 12 m, "
        f"stated on {len(df)} of {len(df)} fixes (validate.gnss.max_h_acc_m "
    )
    if bound is None:
        assert line.endswith("not set: not screened)") and "low_sats" not in out[0]
    else:
        assert line.endswith("5 m: a fix stated worse, or stating none, is cut as low_sats)")
        assert "(cut: partial_second 1 s, low_sats 3 s)" in out[0]  # rows 50.1-52.9 s


def test_a_file_of_many_drives_gives_each_drive_s_verdict(tmp_path, capsys, monkeypatch):
    """A file whose map names each row's drive (``drive: {column: trip_id, unit: text}``):
    ``check`` gives a verdict per drive, named ``fleet.csv (drive T-2)``; ``--drive-id``
    one of them; a refused drive exits 2 naming it and its own row, the others' verdicts
    printed."""
    import pandas as pd

    from rwhonet import paths
    from support.drives import CUPAC_MAP, column_map_params, write_columnmap, write_params_yaml

    frames = []
    for k in (1, 2):
        single = write_columnmap(_turns(), tmp_path / f"T-{k}.csv")
        frames.append(pd.read_csv(single).assign(trip_id=f"T-{k}"))
    fleet = tmp_path / "fleet.csv"
    pd.concat(frames).to_csv(fleet, index=False)
    cmap = column_map_params(CUPAC_MAP) | {"drive": {"column": "trip_id", "unit": "text"}}
    overrides = {"data.column_maps.trips": cmap}
    monkeypatch.setattr(paths, "PARAMS", write_params_yaml(tmp_path / "params.yaml", **overrides))
    args = ["check", "--drive", str(fleet), "--format", "trips", *CAR]
    import rwhonet.data.drivefile as drivefile

    reads = []  # the file is read once for its drives, not again for each
    split = drivefile.split_fleet
    monkeypatch.setattr(drivefile, "split_fleet", lambda *a, **k: reads.append(1) or split(*a, **k))
    assert main(args) == 0
    assert len(reads) == 1
    out = capsys.readouterr().out.splitlines()
    said = [x for x in out if "validate would accept it" in x]
    assert said == [
        f"{fleet} (drive T-{k}): validate would accept it as target's drive" for k in (1, 2)
    ]
    assert main([*args, "--drive-id", "T-2", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["file"] == f"{fleet} (drive T-2)" and record["seconds_kept"] == 150
    assert main([*args, "--drive-id", "T-9"]) == 2
    assert (
        "expected drive 'T-9' among the ids of its column 'trip_id'; found the drives T-1, T-2"
        in capsys.readouterr().err
    )
    table = pd.read_csv(fleet)
    table["WheelSpeedRL"] = table["WheelSpeedRL"].astype(object)
    table.loc[len(frames[0]) + 6, "WheelSpeedRL"] = "fast"
    table.to_csv(fleet, index=False)
    assert main(args) == 2
    captured = capsys.readouterr()
    assert f"{fleet} (drive T-1): validate would accept it" in captured.out
    assert f"{fleet} (drive T-2), row 7, column 'WheelSpeedRL': expected a number" in captured.err
    assert f"in 1 of 2 drives ({fleet} (drive T-2))" in captured.err

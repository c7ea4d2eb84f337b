"""An MDF4 log of raw CAN frames (ASAM bus logging: a CANedge's, a Vector logger's) decoded
with the signal map's CAN database (DBC) by asammdf before its signals are read."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.config import ColumnSpec, DataParams, SignalMapSpec, parse_value
from rwhonet.data import canonical as c
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.errors import InputError
from support.canlog import SIGNALS, write_can_log
from support.serving import wavy_drive

RADIUS_M = 0.31
NAME = "data.signal_maps.canedge.signals"


def _signals() -> dict[str, ColumnSpec]:
    return {k: ColumnSpec(**v) for k, v in SIGNALS.items()}


@pytest.fixture
def log(tmp_path):
    df = wavy_drive(30.0)
    return df, write_can_log(df, tmp_path / "drive.mf4", RADIUS_M)


def test_raw_frames_decoded_by_the_dbc_give_the_drive_s_streams(log):
    """Wheel speeds within the DBC's 0.01 km/h, fixes within 1e-7 deg, the satellite count
    taken at the fixes' times from its own message."""
    df, path = log
    streams = read_mdf4(path, _signals(), RADIUS_M, NAME, dbc=[str(path.with_suffix(".dbc"))])
    (wheels,) = streams.wheels
    t = df[c.T_S].to_numpy() - df[c.T_S].iloc[0]
    np.testing.assert_allclose(wheels.t_s, t, atol=1e-9)
    for w in c.WHEELS:
        step = 0.01 / 3.6 / RADIUS_M  # one count of the DBC's scale, rad/s
        np.testing.assert_allclose(wheels.channels[w], df[w], rtol=0, atol=step / 2 + 1e-9)
    fix = df[c.LAT_DEG].notna().to_numpy()
    np.testing.assert_allclose(streams.gnss.t_s, t[fix] + 0.002, atol=1e-9)
    np.testing.assert_allclose(streams.gnss.channels[c.LAT_DEG], df.loc[fix, c.LAT_DEG], atol=6e-8)
    np.testing.assert_array_equal(streams.gnss.channels[c.N_SATS], df.loc[fix, c.N_SATS])
    assert (
        f"{path}: raw CAN frames decoded with drive.dbc: 3 of the log's 3 frame IDs defined"
        in streams.notes
    )


def test_raw_frames_without_a_dbc_are_said_to_need_one(log):
    _, path = log
    with pytest.raises(InputError) as err:
        read_mdf4(path, _signals(), RADIUS_M, NAME)
    problem = err.value.problems[0]
    assert "CAN_DataFrame" in problem.found
    assert "raw CAN frames: give data.signal_maps.canedge.dbc" in problem.fix


def test_a_dbc_missing_or_of_another_bus_is_refused_by_name(log, tmp_path):
    _, path = log
    with pytest.raises(InputError) as err:
        read_mdf4(path, _signals(), RADIUS_M, NAME, dbc=[str(tmp_path / "none.dbc")])
    assert err.value.problems[0].file == str(tmp_path / "none.dbc")
    assert "no such file" in err.value.problems[0].found
    other = tmp_path / "other.dbc"
    other.write_text(path.with_suffix(".dbc").read_text().replace("BO_ 416 ", "BO_ 417 "))
    other.write_text(
        other.read_text().replace("BO_ 1536 ", "BO_ 1538 ").replace("BO_ 1537", "BO_ 1539")
    )
    with pytest.raises(InputError) as err:
        read_mdf4(path, _signals(), RADIUS_M, NAME, dbc=[str(other)])
    (problem,) = err.value.problems
    assert "3 frame ID(s) (0x1A0, 0x600, 0x601), none in" in problem.found


def test_a_dbc_for_a_file_of_decoded_signals_is_refused(tmp_path):
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    mdf.append([Signal(np.zeros(3), np.arange(3.0), name="WhlSpd_FL", unit="km/h")])
    mdf.save(tmp_path / "decoded.mf4", overwrite=True)
    mdf.close()
    dbc = tmp_path / "can.dbc"
    dbc.write_text('VERSION ""\n')
    with pytest.raises(InputError) as err:
        read_mdf4(tmp_path / "decoded.mf4", _signals(), RADIUS_M, NAME, dbc=[str(dbc)])
    (problem,) = err.value.problems
    assert "raw CAN frames" in problem.expected and "WhlSpd_FL" in problem.found
    assert "remove data.signal_maps.canedge.dbc" in problem.fix


def test_a_dbc_is_one_file_or_a_list_for_either_reader():
    """One database or a list; a stream_csv map may have them too (since stop 64: a bus
    tool's CAN log among the folder's CSVs)."""
    spec = parse_value(SignalMapSpec, {"reader": "mdf4", "signals": SIGNALS, "dbc": "can.dbc"}, "m")
    assert len(spec.dbc_files) == 1 and spec.dbc_files[0].endswith("/can.dbc")
    two = parse_value(SignalMapSpec, {"reader": "mdf4", "signals": SIGNALS, "dbc": ["a", "b"]}, "m")
    assert [f.rsplit("/", 1)[1] for f in two.dbc_files] == ["a", "b"]
    per_bus = {"reader": "mdf4", "signals": SIGNALS, "dbc": {"can0": "a", 2: ["b", "c"]}}
    spec = parse_value(SignalMapSpec, per_bus, "m")
    assert [(f.rsplit("/", 1)[1], b) for f, b in spec.dbc_buses] == [
        ("a", "can0"),
        ("b", "2"),
        ("c", "2"),
    ]
    assert [f.rsplit("/", 1)[1] for f in spec.dbc_files] == ["a", "b", "c"]
    csv = SignalMapSpec("stream_csv", _signals(), dbc=["can.dbc"])
    data = DataParams("files", "data/raw", {}, {}, signal_maps={"logger": csv})
    assert data.signal_maps["logger"].dbc_files[0].endswith("/can.dbc")


def test_an_mdf4_bus_log_s_database_per_bus_channel(log):
    """A database given to the MDF4 bus log's bus channel 1 (its only one) decodes it as
    for every bus; given to channel 2, it is refused, naming the log's channels."""
    _, path = log
    dbc = str(path.with_suffix(".dbc"))
    every = read_mdf4(path, _signals(), RADIUS_M, NAME, dbc=[dbc])
    one = read_mdf4(path, _signals(), RADIUS_M, NAME, dbc=[(dbc, "1")])
    np.testing.assert_array_equal(
        one.wheels[0].channels[c.OMEGA_FL], every.wheels[0].channels[c.OMEGA_FL]
    )
    with pytest.raises(InputError) as err:
        read_mdf4(path, _signals(), RADIUS_M, NAME, dbc=[(dbc, "2")])
    (problem,) = err.value.problems
    assert problem.found == "the log's buses are 1" and "bus channel number" in problem.fix

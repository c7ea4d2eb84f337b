"""A wheel's pulse counter as its speed (rwhonet.data.wheelpulses), alone and through the
stream readers."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec, ConfigError
from rwhonet.data import canonical as c
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.data.signalmap import check_signal_map
from rwhonet.data.streamcsv import read_stream_csvs
from rwhonet.data.streams import resample
from rwhonet.data.wheelpulses import (
    MAX_WHEEL_RAD_S,
    PulseUnit,
    is_pulse_unit,
    pulse_unit,
    pulses_to_rad_s,
)
from rwhonet.errors import InputError
from support.multirate import per_second

TEETH = 96  # pulses a turn
WRAP = 1024  # a 10-bit counter


def _counts(t, rad_s, start, per_turn=TEETH, modulus=WRAP):
    """A pulse counter's values at times ``t`` for a wheel turning at ``rad_s``: the
    teeth gone by since a count of ``start``, wrapped."""
    angle = np.concatenate([[0.0], np.cumsum(0.5 * (rad_s[1:] + rad_s[:-1]) * np.diff(t))])
    n = start + np.floor(angle * per_turn / (2.0 * math.pi))
    return n if modulus is None else np.mod(n, modulus)


def test_units():
    assert pulse_unit("pulses/96 mod 1024") == PulseUnit(96, 1024)
    assert pulse_unit("Pulses / 48") == PulseUnit(48, None)
    assert pulse_unit(" pulses/100  mod 256 ") == PulseUnit(100, 256)
    for unit in ("pulses/0", "pulses/96 mod 1", "pulses", "pulses/9.6", "rad/s", "96 mod 1024"):
        assert not is_pulse_unit(unit), unit


def test_a_map_takes_a_pulse_unit_for_a_wheel_only():
    wheels = {
        f"omega_{w}": ColumnSpec(f"P{w}", "pulses/96 mod 1024") for w in "fl fr rl rr".split()
    }
    fixes = {"lat": ColumnSpec("Lat", "deg"), "lon": ColumnSpec("Lon", "deg")}
    check_signal_map("m", wheels | fixes)
    with pytest.raises(ConfigError) as err:
        check_signal_map("m", wheels | fixes | {"speed_gnss": ColumnSpec("V", "pulses/96")})
    assert "signals.speed_gnss.unit: expected one of ['m/s', 'km/h', 'mph'], got" in str(err.value)
    with pytest.raises(ConfigError) as err:
        check_signal_map("m", wheels | fixes | {"omega_fl": ColumnSpec("Pfl", "pulses/0")})
    assert "or pulses/N or pulses/N mod M (a pulse counter" in str(err.value)


def test_a_steady_wheel_s_counts_give_its_speed_across_the_wrap():
    """50 rad/s at 100 Hz, the counter wrapping five times: every sample's speed within a
    pulse over its span (0.2 s about it, less at the ends) of the truth, their mean the
    truth, and the speeds' integral the counted angle within a pulse."""
    t = np.arange(0.0, 12.0, 0.01)
    counts = _counts(t, np.full(t.size, 50.0), start=1000)
    assert (np.diff(counts) < 0).sum() >= 5  # it wrapped
    got = pulses_to_rad_s(t, counts, PulseUnit(TEETH, WRAP), "wheels.csv", "Pfl")
    pulse = 2.0 * math.pi / TEETH
    span = np.minimum(t + 0.1, t[-1]) - np.maximum(t - 0.1, t[0])
    assert np.all(np.abs(got.rad_s - 50.0) <= pulse / span + 1e-9)
    assert np.abs(got.rad_s[20:-20] - 50.0).max() <= pulse / 0.2 + 1e-9  # 0.33 rad/s
    assert np.mean(got.rad_s) == pytest.approx(50.0, abs=0.01)
    rolled = np.sum(0.5 * (got.rad_s[1:] + got.rad_s[:-1]) * np.diff(t))
    counted = np.sum(np.mod(np.diff(counts), WRAP)) * pulse
    assert rolled == pytest.approx(counted, abs=pulse)
    assert got.steps == t.size - 1 and not any(got.no_step.values())
    said = got.said("Pfl", PulseUnit(TEETH, WRAP))
    assert said == (
        "Pfl: a pulse counter (96 a turn, wrapping at 1024) as wheel speed, the angle its "
        f"counts turned over 0.2 s about each sample ({t.size - 1} steps)"
    )


def test_steps_that_cannot_tell_the_speed_are_none_and_said():
    """A step longer than the counter can tell its wraps in (10 frames lost at highway
    speed), a count missing, and a counter that does not wrap going back: those steps
    have no speed; the samples beside them take the other step's; a sample with none
    either side has none."""
    t = np.arange(0.0, 2.0, 0.02)
    counts = _counts(t, np.full(t.size, 90.0), start=0)
    span = WRAP / (MAX_WHEEL_RAD_S / (2 * math.pi) * TEETH)
    assert 0.19 < span < 0.21  # 0.20 s: ten 50 Hz frames
    keep = np.r_[0:40, 51 : t.size]  # 0.22 s without a frame
    counts_missing = counts.copy()
    counts_missing[70] = np.nan
    got = pulses_to_rad_s(t[keep], counts_missing[keep], PulseUnit(TEETH, WRAP), "w", "P")
    assert got.no_step == {"a count missing": 2, "too long to tell the wraps": 1, "went back": 0}
    assert np.isnan(got.rad_s[keep == 70]).all()
    finite = got.rad_s[np.isfinite(got.rad_s)]
    assert np.all(np.abs(finite - 90.0) <= 2 * math.pi / TEETH / 0.02 + 1e-9)
    # a counter that does not wrap, going back (the unit restarted)
    plain = _counts(t, np.full(t.size, 90.0), start=5, modulus=None)
    plain[60:] -= plain[60]
    got = pulses_to_rad_s(t, plain, PulseUnit(TEETH, None), "w", "P")
    assert got.no_step["went back"] == 1
    assert np.isfinite(got.rad_s).all()  # each sample beside it has its other step
    assert "steps without a speed: 1 went back" in got.said("P", PulseUnit(TEETH, None))
    # no sample, one sample: no speed
    assert pulses_to_rad_s(np.zeros(0), np.zeros(0), PulseUnit(TEETH, 4), "w", "P").rad_s.size == 0
    assert np.isnan(
        pulses_to_rad_s(np.zeros(1), np.ones(1), PulseUnit(TEETH, 4), "w", "P").rad_s
    ).all()
    # a one-step log's lone step gone: no speed at all
    got = pulses_to_rad_s(np.array([0.0, 1.0]), np.array([1.0, 3.0]), PulseUnit(TEETH, 4), "w", "P")
    assert np.isnan(got.rad_s).all()


@pytest.mark.parametrize(
    ("bad", "said"),
    [(1024.0, "1024"), (-1.0, "-1"), (12.5, "12.5")],
)
def test_a_count_that_is_no_count_is_refused_with_its_row(bad, said):
    t = np.arange(0.0, 1.0, 0.01)
    counts = _counts(t, np.full(t.size, 30.0), start=0)
    counts[[17, 40]] = bad
    rows = np.arange(t.size) + 2  # a header line above
    with pytest.raises(InputError) as err:
        pulses_to_rad_s(t, counts, PulseUnit(TEETH, WRAP), "wheels.csv", "Pfl", rows)
    text = str(err.value)
    assert "wheels.csv" in text and "row 19" in text and "Pfl" in text
    assert "a pulse count, a whole number from 0 to 1023" in text
    assert f"2 count(s) not so (row 19: {said}, row 42: {said})" in text


def _drive():
    from support.multirate import simulated_streams

    return simulated_streams(90.0, 100.0, 10.0)


def _labels(files, smap, radius):
    streams = read_stream_csvs(files, smap, radius)
    resampled = resample(streams, nominal_radius_m=radius)
    assert resampled.glitch_samples == []  # a pulse's step is no tyre's glitch
    return per_second(resampled.drive.columns, radius), streams


def _pulse_csvs(tmp_path, tables, swap=None):
    """The drive's wheels as pulse counters in wheels.csv (each wheel from its own start
    count), its fixes in gnss.csv; ``swap``: two rows of wheels.csv written the other way
    round."""
    from rwhonet.sim.streams import StreamTables, write_stream_csvs

    w = tables.wheels.copy()
    t = w[c.T_S].to_numpy()
    for k, start in zip(c.WHEELS, (3, 500, 1023, 77), strict=True):
        w[k] = _counts(t, w[k].to_numpy(), start)
    if swap is not None:
        w.iloc[[swap, swap + 1]] = w.iloc[[swap + 1, swap]].to_numpy()
    return write_stream_csvs(StreamTables(w, tables.gnss), tmp_path)


def _pulse_map():
    from rwhonet.sim.streams import signal_map

    smap = dict(signal_map())
    return smap | {
        k: ColumnSpec(smap[k].column, "pulses/96 mod 1024")
        for k in ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
    }


def test_a_drive_s_pulse_counters_give_its_labels_within_a_pulse(tmp_path):
    """The simulated drive's wheels as 10-bit counters of 96 pulses a turn at 100 Hz: each
    second's wheel distance within 1.5 pulses of the speeds' (a pulse is 2 cm), the
    drive's within a pulse, the labels alike, no sample taken for a glitch; the notes say
    how the counters were read."""
    from rwhonet.sim.streams import signal_map, write_stream_csvs

    tables, radius = _drive()
    want, _ = _labels(
        list(write_stream_csvs(tables, tmp_path / "speeds").values()), signal_map(), radius
    )
    got, streams = _labels(
        list(_pulse_csvs(tmp_path / "pulses", tables).values()), _pulse_map(), radius
    )
    assert len(got) == len(want) > 60
    np.testing.assert_array_equal(got["t_s"], want["t_s"])
    pulse_m = 2.0 * math.pi / TEETH * radius
    for q in ("disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], want[q], rtol=0, atol=1.5 * pulse_m)
    assert abs(got["disp_wpm_m"].sum() - want["disp_wpm_m"].sum()) < pulse_m
    said = " ".join(streams.notes)
    assert (
        "WheelSpeed_FL: a pulse counter (96 a turn, wrapping at 1024) as wheel speed, the "
        "angle its counts turned over 0.2 s about each sample (8990 steps)"
    ) in said


def test_counts_written_out_of_order_are_put_in_order_before_they_are_differenced(tmp_path):
    """Two rows of wheels.csv the other way round (at 20 m/s): the reader puts them in
    order first, so the speeds and labels are those of the counts in order, exactly."""
    tables, radius = _drive()
    assert tables.wheels[c.WHEELS[0]].iloc[3400] * radius > 15.0
    want, _ = _labels(list(_pulse_csvs(tmp_path / "a", tables).values()), _pulse_map(), radius)
    got, streams = _labels(
        list(_pulse_csvs(tmp_path / "b", tables, swap=3400).values()), _pulse_map(), radius
    )
    pd.testing.assert_frame_equal(got, want)
    assert any("out of time order" in n or "in time order" in n for n in streams.changed)


PULSE_DBC_MESSAGE = """
BO_ 417 WheelPulses: 8 ESC
 SG_ Puls_FL : 0|10@1+ (1,0) [0|1023] "" Vector__XXX
 SG_ Puls_FR : 10|10@1+ (1,0) [0|1023] "" Vector__XXX
 SG_ Puls_RL : 20|10@1+ (1,0) [0|1023] "" Vector__XXX
 SG_ Puls_RR : 30|10@1+ (1,0) [0|1023] "" Vector__XXX
"""


def test_a_can_bus_s_pulse_counters_through_a_dbc_give_the_labels_of_its_speeds(tmp_path):
    """An ESC's four 10-bit pulse counters in one 50 Hz message (as Volkswagen's ESP_10),
    decoded by the DBC from a candump log: the labels of the same drive's speeds in the
    same log within 1.5 pulses a second."""
    from support.canlog import DBC, SIGNALS, WHEELS_ID, stream_frames, write_candump
    from support.multirate import simulated_streams

    tables, radius = simulated_streams(60.0, 50.0, 5.0)
    stamps, ids, data = stream_frames(tables, radius, 1_700_000_000.0)
    w = tables.wheels
    t = w[c.T_S].to_numpy()
    counts = np.stack(
        [
            _counts(t, w[k].to_numpy(), s).astype(np.uint64)
            for k, s in zip(c.WHEELS, (0, 9, 600, 1020), strict=True)
        ]
    )
    packed = counts[0] | counts[1] << 10 | counts[2] << 20 | counts[3] << 30
    pulses = data.copy()
    wheel_rows = np.flatnonzero(ids == WHEELS_ID)
    assert wheel_rows.size == t.size
    pulses[wheel_rows] = packed.astype("<u8").view(np.uint8).reshape(-1, 8)
    pulse_ids = np.where(ids == WHEELS_ID, 417, ids)
    (tmp_path / "bus.dbc").write_text(DBC + PULSE_DBC_MESSAGE)
    dbc = [str(tmp_path / "bus.dbc")]
    base = {"t": ColumnSpec("t", "s")} | {k: ColumnSpec(**v) for k, v in SIGNALS.items()}
    by_pulses = base | {
        f"omega_{x}": ColumnSpec(f"Puls_{x.upper()}", "pulses/96 mod 1024")
        for x in ("fl", "fr", "rl", "rr")
    }
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    speeds = write_candump(stamps, ids, data, tmp_path / "a" / "can0.log")
    counted = write_candump(stamps, pulse_ids, pulses, tmp_path / "b" / "can0.log")

    def labels(log, smap):
        streams = read_stream_csvs([log], smap, radius, "m", {log: "can0.log"}, dbc)
        resampled = resample(streams, nominal_radius_m=radius)
        assert resampled.glitch_samples == []
        return per_second(resampled.drive.columns, radius), streams

    want, _ = labels(speeds, base)
    got, streams = labels(counted, by_pulses)
    # the same log as a map with ``reader: mdf4`` reads it (one bus tool's log, its own clock)
    alone = read_mdf4(
        counted, {k: v for k, v in by_pulses.items() if k != "t"}, radius, "m", dbc=dbc
    )
    alone_drive = resample(alone, nominal_radius_m=radius).drive.columns
    np.testing.assert_allclose(
        per_second(alone_drive, radius)["disp_wpm_m"].sum(), got["disp_wpm_m"].sum(), rtol=1e-9
    )
    assert len(got) == len(want) > 40
    pulse_m = 2.0 * math.pi / TEETH * radius
    np.testing.assert_allclose(got["disp_wpm_m"], want["disp_wpm_m"], rtol=0, atol=1.5 * pulse_m)
    assert "can0.log [WheelPulses 0x1A1]: Puls_FL: a pulse counter (96 a turn" in " ".join(
        streams.notes
    )


def _mdf4(tables, path, unit):
    """The streams as an MDF4 file of decoded signals, the wheels' declared ``unit``."""
    from asammdf import MDF, Signal

    from rwhonet.sim.streams import GNSS_COLUMNS, WHEEL_COLUMNS

    mdf = MDF(version="4.10")
    t_w = tables.wheels[c.T_S].to_numpy(np.float64)
    mdf.append(
        [
            Signal(tables.wheels[k].to_numpy(np.float64), t_w, name=n, unit=unit)
            for k, n in WHEEL_COLUMNS.items()
        ]
    )
    t_g = tables.gnss[c.T_S].to_numpy(np.float64)
    mdf.append(
        [
            Signal(tables.gnss[k].to_numpy(np.float64), t_g, name=n, unit="")
            for k, n in GNSS_COLUMNS.items()
        ]
    )
    mdf.save(path, overwrite=True)
    mdf.close()
    return path


def test_an_mdf4_file_s_counters_read_as_the_csvs_and_a_speed_unit_contradicts(tmp_path):
    """The counters as decoded MDF4 signals (unit ``-``, or none) give the labels of the
    same counters in CSVs; a file that declares them ``rad/s`` contradicts the map."""
    from rwhonet.sim.streams import StreamTables

    tables, radius = _drive()
    want, _ = _labels(list(_pulse_csvs(tmp_path / "csv", tables).values()), _pulse_map(), radius)
    w = tables.wheels.copy()
    t = w[c.T_S].to_numpy()
    for k, start in zip(c.WHEELS, (3, 500, 1023, 77), strict=True):
        w[k] = _counts(t, w[k].to_numpy(), start)
    counted = StreamTables(w, tables.gnss)
    smap = {k: v for k, v in _pulse_map().items() if k != "t"}
    for unit in ("-", "", "count"):
        streams = read_mdf4(_mdf4(counted, tmp_path / "d.mf4", unit), smap, radius, "m")
        got = per_second(resample(streams, nominal_radius_m=radius).drive.columns, radius)
        pd.testing.assert_frame_equal(got, want, check_exact=False, rtol=0, atol=1e-9)
    with pytest.raises(InputError) as err:
        read_mdf4(_mdf4(counted, tmp_path / "e.mf4", "rad/s"), smap, radius, "m")
    said = str(err.value)
    assert "the unit 'pulses/96 mod 1024' (m.omega_fl)" in said and "the file says 'rad/s'" in said


def test_a_column_map_refuses_a_pulse_unit_saying_why():
    from rwhonet.data.columnmap import check_column_map

    cmap = {
        "t": ColumnSpec("t", "s"),
        "lat": ColumnSpec("Lat", "deg"),
        "lon": ColumnSpec("Lon", "deg"),
    } | {f"omega_{w}": ColumnSpec(f"P{w}", "pulses/96 mod 1024") for w in ("fl", "fr", "rl", "rr")}
    with pytest.raises(ConfigError) as err:
        check_column_map("logger", cmap)
    said = str(err.value)
    assert "data.column_maps.logger.omega_fl.unit: expected one of" in said
    assert "a pulse counter is differenced sample to sample" in said


def test_a_header_that_says_a_speed_unit_contradicts_a_pulse_counter(tmp_path):
    """wheels.csv whose wheel columns say ``(rad/s)``, mapped as pulse counters: refused,
    naming the header, as any unit the map contradicts."""
    tables, radius = _drive()
    files = _pulse_csvs(tmp_path, tables)
    text = files["wheels"].read_text()
    head, rest = text.split("\n", 1)
    files["wheels"].write_text(head.replace("WheelSpeed_FL", "WheelSpeed_FL (rad/s)") + "\n" + rest)
    with pytest.raises(InputError) as err:
        _labels(list(files.values()), _pulse_map(), radius)
    said = str(err.value)
    assert "WheelSpeed_FL (rad/s)" in said and "the header says 'rad/s'" in said
    assert "the unit 'pulses/96 mod 1024'" in said

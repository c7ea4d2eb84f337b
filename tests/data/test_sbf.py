"""A Septentrio receiver's SBF log (``rwhonet.data.sbf``), written by ``pysbf2``: its fixes'
labels are those of the same fixes in gnss.csv; each field as pysbf2 parses it; what is
no fix, what is damaged, and the leap seconds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.sbf import is_sbf_name, read_sbf
from rwhonet.data.streamcsv import log_kind
from rwhonet.errors import InputError
from support.multirate import fixes_to_the_ms, receiver_drive, receiver_folder, receiver_labels
from support.sbf import (
    DNU,
    GPS_EPOCH_UNIX_S,
    LEAP_S,
    NO_H_ACCURACY,
    dop,
    pvt,
    pvt_untimed,
    revised,
    sbf_blocks,
    write_sbf,
)

DAY_S = 1_552_262_400.0  # 2019-03-11 00:00:00 UTC
GPS_S = DAY_S + 45_000.0 - GPS_EPOCH_UNIX_S + LEAP_S


def test_the_sbf_log_gives_the_labels_of_the_csv_fixes(tmp_path):
    """wheels.csv on the time of day, the fixes as log.sbf (PVTGeodetic, ReceiverTime
    every 10 epochs, a DOP block after each): the labels of the same fixes in gnss.csv,
    within 0.01 mm."""
    g = fixes_to_the_ms()
    ref, _ = receiver_labels(list(receiver_folder(tmp_path / "csv", g).values()))
    wheels = receiver_folder(tmp_path / "sbf", g.iloc[:0])["wheels"]
    log_ = write_sbf(tmp_path / "sbf" / "log.sbf", sbf_blocks(g, DAY_S + g[c.T_S]))
    assert log_kind(log_.name, log_) == "SBF"
    got, streams = receiver_labels([wheels, log_])
    assert len(got) == len(ref) > 100
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-5, err_msg=q)
    said = " ".join(streams.notes)
    assert f"an SBF log: {len(g)} epochs (PVTGeodetic), {len(g)} with a fix" in said
    assert "by its ReceiverTime blocks' DeltaLS (18 s)" in said
    assert f"besides them: DOP {len(g)}" in said
    gnss = next(s for s in streams.streams if s.name == "log.sbf")
    assert gnss.sources[c.LAT_DEG] == "PVTGeodetic Latitude" and gnss.rows[0] == 2


def test_every_field_is_as_pysbf2_parses_it(tmp_path):
    """Position, height above the geoid, satellites, speed and course, epoch by epoch, as
    pysbf2's reader gives the same blocks (the height: Height less Undulation)."""
    from pysbf2 import SBFReader

    g = fixes_to_the_ms()
    turn = np.linspace(0.0, 350.0, len(g))
    g = g.assign(**{c.SPEED_GNSS_M_S: 8.0 + np.sin(turn / 50.0), c.HEADING_DEG: turn})
    log_ = write_sbf(tmp_path / "log.sbf", sbf_blocks(g, DAY_S + g[c.T_S]))
    fixes = read_sbf(log_, "log.sbf")
    with open(log_, "rb") as f:
        theirs = [p for _, p in SBFReader(f) if p.identity == "PVTGeodetic"]
    assert len(theirs) == fixes.rows.size
    np.testing.assert_array_equal(fixes.channels["lat"], [math.degrees(p.Latitude) for p in theirs])
    np.testing.assert_array_equal(
        fixes.channels["lon"], [math.degrees(p.Longitude) for p in theirs]
    )
    np.testing.assert_allclose(
        fixes.channels["height"], [p.Height - p.Undulation for p in theirs], rtol=0, atol=1e-9
    )
    np.testing.assert_array_equal(fixes.channels["n_sats"], [p.NrSV for p in theirs])
    np.testing.assert_allclose(
        fixes.channels["speed_gnss"], [math.hypot(p.Vn, p.Ve) for p in theirs], atol=1e-9
    )
    np.testing.assert_allclose(fixes.channels["heading"], [p.COG for p in theirs], atol=1e-9)
    utc = fixes.day_s + fixes.tod_s
    gps = [p.WNc * 604_800 + p.TOW / 1000.0 for p in theirs]  # pysbf2 gives TOW in ms
    np.testing.assert_allclose(utc, np.array(gps) + GPS_EPOCH_UNIX_S - LEAP_S, atol=1e-6)


@pytest.mark.parametrize(
    ("mode", "error", "fix"),
    [
        (1, 0, True),  # stand-alone
        (4, 0, True),  # RTK fixed
        (10, 0, True),  # PPP
        (0x81, 0, True),  # stand-alone, 2D
        (0, 0, False),  # no PVT
        (3, 0, False),  # a fixed location, set by command
        (1, 4, False),  # an error
    ],
)
def test_what_is_a_fix(tmp_path, mode, error, fix):
    blocks = [
        pvt(GPS_S, Type=1, Error=0, Latitude=0.91, Longitude=-0.03, NrSV=9),
        pvt(
            GPS_S + 0.1,
            Type=mode & 0x0F,
            **{"2D": mode >> 7},
            Error=error,
            Latitude=0.91,
            Longitude=-0.03,
            NrSV=9,
        ),
    ]
    got = read_sbf(write_sbf(tmp_path / "log.sbf", blocks), "log.sbf")
    assert np.isfinite(got.channels["lat"][1]) == fix
    assert np.isfinite(got.channels["lon"][1]) == fix


def test_do_not_use_fields_are_missing(tmp_path):
    """A field the receiver does not know holds its do-not-use value: missing in that
    epoch; a position of one is no fix; a field no epoch has is no channel."""
    known = {"Height": 160.0, "Undulation": 48.0, "Vn": 3.0, "Ve": 4.0, "COG": 36.87}
    blocks = [
        pvt(GPS_S, Type=1, Latitude=0.91, Longitude=-0.03, **known, NrSV=9),
        pvt(
            GPS_S + 0.1,
            Type=1,
            Latitude=0.91,
            Longitude=-0.03,
            Height=DNU,
            Undulation=48.0,
            Vn=DNU,
            Ve=1.0,
            COG=DNU,
            NrSV=255,
        ),
        pvt(GPS_S + 0.2, Type=1, Latitude=DNU, Longitude=-0.03, **known, NrSV=7),
    ]
    got = read_sbf(write_sbf(tmp_path / "log.sbf", blocks), "log.sbf")
    assert got.channels["height"][0] == 112.0 and got.channels["speed_gnss"][0] == 5.0
    for key in ("height", "speed_gnss", "heading", "n_sats"):
        assert np.isnan(got.channels[key][1]), key
    assert np.isnan(got.channels["lat"][2]) and np.isnan(got.channels["lon"][2])
    assert got.channels["n_sats"][2] == 7
    none = [pvt(GPS_S, Type=1, Latitude=0.91, Longitude=-0.03, Vn=DNU, Ve=DNU, COG=DNU)]
    assert "speed_gnss" not in read_sbf(write_sbf(tmp_path / "n.sbf", none), "n.sbf").channels


def test_damage_is_passed_over_and_counted(tmp_path):
    """A block with a byte changed (its CRC), one cut by the file's end, an epoch given
    twice, one of a do-not-use time; a DOP block whose PDOP's bytes are ``$@`` and whose
    next fields make a block's header (a sync pair inside a good block) is no block."""
    good = [pvt(GPS_S + k * 0.1, Type=1, Latitude=0.91, Longitude=-0.03, NrSV=9) for k in range(6)]
    flipped = bytearray(good[2])
    flipped[20] ^= 0xFF
    untimed = pvt_untimed()
    # PDOP 16420 (0x4024: "$@" little-endian), then TDOP, HDOP and VDOP 8 where a block's
    # CRC, ID and length would be: a block of 8 bytes to a reader that looked inside
    sync_inside = dop(GPS_S, pdop=164.20, vdop=0.08)
    assert b"$@" in sync_inside[2:]
    blocks = [
        good[0],
        sync_inside,
        good[1],
        bytes(flipped),
        good[3],
        good[3],
        untimed,
        good[4],
        good[5][:50],
    ]
    got = read_sbf(write_sbf(tmp_path / "log.sbf", blocks), "log.sbf")
    assert got.rows.tolist() == [1, 3, 4, 7]  # good blocks: PVT, DOP, PVT, PVT, PVT, PVT, PVT
    start = sum(len(b) for b in blocks[:3])
    assert got.dropped == (
        f"1 block(s) whose CRC does not match (first at byte {start}); 1 block(s) cut short "
        f"(first at byte {sum(len(b) for b in blocks[:8])}); 1 PVTGeodetic block(s) of a "
        "do-not-use time (first: block 6); 1 PVTGeodetic block(s) of an epoch already given "
        "(first: block 5)"
    )


def test_without_receiver_time_the_leap_seconds_table_puts_it_on_utc(tmp_path):
    g = fixes_to_the_ms()
    log_ = write_sbf(tmp_path / "log.sbf", sbf_blocks(g, DAY_S + g[c.T_S], leap=False))
    got = read_sbf(log_, "log.sbf")
    np.testing.assert_allclose(got.day_s + got.tod_s, DAY_S + g[c.T_S], rtol=0, atol=1e-6)
    assert "by the leap seconds to its date (18 s; no ReceiverTime block" in got.notes[0]


def test_a_log_without_pvtgeodetic_is_refused_naming_what_it_holds(tmp_path):
    log_ = write_sbf(tmp_path / "log.sbf", [dop(GPS_S), dop(GPS_S + 1)])
    with pytest.raises(InputError) as err:
        read_sbf(log_, "log.sbf")
    (problem,) = err.value.problems
    assert problem.found == "DOP 2" and "PVTGeodetic" in problem.fix


def test_names():
    assert is_sbf_name("log.sbf") and is_sbf_name("LOG.SBF.gz") and is_sbf_name("sept3400.24_")
    assert not is_sbf_name("gps.nmea") and not is_sbf_name("log.sbf.csv")


def test_a_drive_folder_s_sbf_log_kept_compressed_or_named_by_the_receiver(tmp_path):
    """Through ingest's reader (``read_any``), a folder's ``log.sbf.gz`` and a receiver's
    own ``sept3400.19_`` give the grid of its ``log.sbf``, bit for bit."""
    import gzip

    from rwhonet.data.drivefile import DriveFile, read_any
    from support.drives import make_params
    from support.stream_fleet import signal_map_params

    g = fixes_to_the_ms()
    raw = b"".join(sbf_blocks(g, DAY_S + g[c.T_S]))
    smap = {"data.signal_maps": {"logger": signal_map_params("stream_csv")}}
    grids = {}
    for name in ("log.sbf", "log.sbf.gz", "sept3400.19_"):
        folder = tmp_path / name.replace(".", "_")
        for k, written in receiver_folder(folder, g.iloc[:0]).items():
            if k != "wheels":  # the fixes are the log's
                written.unlink()
        (folder / name).write_bytes(gzip.compress(raw, mtime=0) if name.endswith(".gz") else raw)
        f = DriveFile(name, "target_test", "target", "logger", folder)
        data = make_params(tmp_path, **smap).data
        grids[name] = read_any(f, data, lambda p: p.name, receiver_drive()[1], 0.1, 10.0)[0]
    assert np.isfinite(grids["log.sbf"].columns[c.LAT_DEG]).sum() > 1000
    for name in ("log.sbf.gz", "sept3400.19_"):
        for k, v in grids["log.sbf"].columns.items():
            np.testing.assert_array_equal(grids[name].columns[k], v, err_msg=f"{name} {k}")


def test_the_stated_accuracy_is_half_haccuracy_s_2drms(tmp_path):
    """A revision 2 PVTGeodetic's HAccuracy (0.01 m, 2DRMS) halved is h_acc, the DRMS in
    metres: 250 gives 1.25 m; its do-not-use 65535 (a block without a PVT too) is NaN; the
    values as pysbf2 parses the same blocks, halved."""
    from pysbf2 import SBFReader

    fixed = {"Type": 1, "Latitude": 0.91, "Longitude": -0.03, "NrSV": 9}
    blocks = [
        pvt(GPS_S, **fixed, HAccuracy=2.5),
        pvt(GPS_S + 0.1, **fixed, HAccuracy=NO_H_ACCURACY),
        pvt(GPS_S + 0.2, **fixed, HAccuracy=0.8),
        pvt(GPS_S + 0.3, Type=0, Error=1, Latitude=DNU, Longitude=DNU),
    ]
    path = write_sbf(tmp_path / "log.sbf", blocks)
    assert int.from_bytes(blocks[0][90:92], "little") == 250
    got = read_sbf(path, "log.sbf")
    np.testing.assert_array_equal(got.channels["h_acc"], [1.25, np.nan, 0.4, np.nan])
    assert got.channels["h_acc"].dtype == np.float64
    assert got.sources["h_acc"] == "PVTGeodetic HAccuracy"
    with open(path, "rb") as f:
        theirs = [p.HAccuracy / 2.0 for _, p in SBFReader(f) if p.identity == "PVTGeodetic"]
    np.testing.assert_allclose(got.channels["h_acc"][[0, 2]], [theirs[0], theirs[2]], atol=1e-12)


def test_blocks_before_revision_2_state_no_accuracy(tmp_path):
    """Revision 0 and 1 PVTGeodetic blocks (88 bytes) have no HAccuracy: a log of them has
    no h_acc, its other channels as before; a revision 2 block's bytes under a revision 0
    ID (its HAccuracy unread: the ID says the field is not there) states none either. In a
    log of both, only the revision 2 blocks state one."""
    fixed = {"Type": 1, "Latitude": 0.91, "Longitude": -0.03, "NrSV": 9}
    old = [pvt(GPS_S + k * 0.1, revision=k % 2, **fixed) for k in range(4)]
    assert {len(b) for b in old} == {88}
    got = read_sbf(write_sbf(tmp_path / "old.sbf", old), "old.sbf")
    assert "h_acc" not in got.channels and "h_acc" not in got.sources
    assert got.channels["n_sats"].tolist() == [9.0] * 4
    unrevised = revised(pvt(GPS_S, **fixed, HAccuracy=2.5), 0)
    assert len(unrevised) == 96
    got = read_sbf(write_sbf(tmp_path / "id0.sbf", [unrevised]), "id0.sbf")
    assert "h_acc" not in got.channels
    both = [old[0], pvt(GPS_S + 0.1, **fixed, HAccuracy=2.5)]
    got = read_sbf(write_sbf(tmp_path / "both.sbf", both), "both.sbf")
    np.testing.assert_array_equal(got.channels["h_acc"], [np.nan, 1.25])


def test_the_sbf_log_s_stated_accuracy_reaches_the_drive(tmp_path):
    """log.sbf beside wheels.csv, each fix's HAccuracy twice the table's h_acc_m: the GNSS
    stream's h_acc_m is the table's (to HAccuracy's 0.005 m DRMS), and the resampled
    drive has the column; without HAccuracy (the writer's do-not-use), no column."""
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample
    from rwhonet.sim.streams import signal_map

    g = fixes_to_the_ms()
    g = g.assign(**{c.H_ACC_M: 0.5 + 0.01 * (np.arange(len(g)) % 50)})
    _, radius = receiver_drive()
    wheels = receiver_folder(tmp_path / "sbf", g.iloc[:0])["wheels"]
    log_ = write_sbf(tmp_path / "sbf" / "log.sbf", sbf_blocks(g, DAY_S + g[c.T_S]))
    streams = read_stream_csvs([wheels, log_], signal_map(), radius)
    np.testing.assert_allclose(streams.gnss.channels[c.H_ACC_M], g[c.H_ACC_M], atol=0.0051)
    assert streams.gnss.sources[c.H_ACC_M] == "PVTGeodetic HAccuracy"
    drive = resample(streams, nominal_radius_m=radius).drive.columns
    assert np.isfinite(drive[c.H_ACC_M]).sum() > 1000
    plain = write_sbf(
        tmp_path / "sbf" / "log.sbf", sbf_blocks(g.drop(columns=c.H_ACC_M), DAY_S + g[c.T_S])
    )
    streams = read_stream_csvs([wheels, plain], signal_map(), radius)
    assert c.H_ACC_M not in streams.gnss.channels
    assert c.H_ACC_M not in resample(streams, nominal_radius_m=radius).drive.columns


def test_a_block_given_again_leaves_the_accuracies_with_their_epochs(tmp_path):
    """An epoch's PVTGeodetic written twice (the second passed over, counted): each epoch
    keeps its own block's HAccuracy, the copy's not shifting the rest."""
    fixed = {"Type": 1, "Latitude": 0.91, "Longitude": -0.03, "NrSV": 9}
    blocks = [
        pvt(GPS_S, **fixed, HAccuracy=1.0),
        pvt(GPS_S, **fixed, HAccuracy=9.0),  # the same epoch again
        pvt(GPS_S + 0.1, **fixed, HAccuracy=3.0),
    ]
    got = read_sbf(write_sbf(tmp_path / "again.sbf", blocks), "again.sbf")
    np.testing.assert_array_equal(got.channels["h_acc"], [0.5, 1.5])
    assert got.channels["n_sats"].size == 2


def test_a_pvtcartesian_log_gives_what_the_pvtgeodetic_log_of_the_same_fixes_gives(tmp_path):
    """The drive's fixes as PVTCartesian blocks (X, Y, Z and Vx, Vy, Vz in ECEF, written by
    the closed form, not PROJ): the labels of the same fixes as PVTGeodetic blocks within
    0.01 mm; each epoch's latitude and longitude within 1e-9 degrees (0.1 mm), its height
    within 1 mm, its speed within f4's rounding, its satellites, course and accuracy the
    same; the notes name the block."""
    g = fixes_to_the_ms()
    turn = np.linspace(0.0, 350.0, len(g))
    g = g.assign(**{c.SPEED_GNSS_M_S: 8.0 + np.sin(turn / 50.0), c.HEADING_DEG: turn})
    g = g.assign(**{c.H_ACC_M: np.full(len(g), 1.25)})
    wheels = receiver_folder(tmp_path / "w", g.iloc[:0])["wheels"]
    logs = {}
    for kind in ("geodetic", "cartesian"):
        blocks = sbf_blocks(g, DAY_S + g[c.T_S], cartesian=kind == "cartesian")
        logs[kind] = write_sbf(tmp_path / kind / "log.sbf", blocks)
    geo, cart = (read_sbf(logs[k], "log.sbf") for k in ("geodetic", "cartesian"))
    for key in ("lat", "lon"):
        np.testing.assert_allclose(cart.channels[key], geo.channels[key], rtol=0, atol=1e-9)
    np.testing.assert_allclose(cart.channels["height"], geo.channels["height"], atol=1e-3)
    np.testing.assert_allclose(cart.channels["speed_gnss"], geo.channels["speed_gnss"], atol=1e-5)
    for key in ("n_sats", "heading", "h_acc"):
        np.testing.assert_array_equal(cart.channels[key], geo.channels[key], err_msg=key)
    np.testing.assert_array_equal(cart.tod_s, geo.tod_s)
    assert cart.sources["lat"] == "PVTCartesian X, Y, Z"
    assert cart.sources["speed_gnss"] == "PVTCartesian Vx, Vy, Vz"
    assert cart.sources["n_sats"] == "PVTCartesian NrSV"
    said = " ".join(cart.notes)
    assert f"an SBF log: {len(g)} epochs (PVTCartesian), {len(g)} with a fix" in said
    assert "besides them: DOP" in said and "PVTCartesian" not in said.split("besides them:")[1]
    ref = receiver_labels([wheels, logs["geodetic"]])[0]
    got = receiver_labels([wheels, logs["cartesian"]])[0]
    assert len(got) == len(ref) > 100
    for q in ("t_s", "disp_gnss_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-5, err_msg=q)


def test_pvtcartesian_beside_pvtgeodetic_no_fix_and_a_position_off_the_earth(tmp_path):
    """A log with both blocks is read by PVTGeodetic, PVTCartesian counted. PVTCartesian's
    epoch without a fix (mode 0, do-not-use X, Y, Z) is kept without a position. A fix at
    X = Y = Z = 1000 m (thousands of km below the ellipsoid) is refused with its block and
    byte."""
    g = fixes_to_the_ms().iloc[:5].reset_index(drop=True)
    t = DAY_S + g[c.T_S]
    both = sbf_blocks(g, t) + sbf_blocks(g, t, leap=False, cartesian=True)[::2]
    log = read_sbf(write_sbf(tmp_path / "both.sbf", both), "both.sbf")
    assert log.sources["lat"] == "PVTGeodetic Latitude"
    assert "PVTCartesian 5" in " ".join(log.notes)
    gap = g.assign(**{c.LAT_DEG: [52.4, np.nan, 52.4, 52.4, 52.4]})
    log = read_sbf(write_sbf(tmp_path / "gap.sbf", sbf_blocks(gap, t, cartesian=True)), "g.sbf")
    assert np.isnan(log.channels["lat"][1]) and np.isfinite(log.channels["lat"]).sum() == 4
    assert "5 epochs (PVTCartesian), 4 with a fix" in log.notes[0]
    # a fix whose Z alone is do-not-use: no position, not one thousands of km off
    blocks = sbf_blocks(g, t, cartesian=True)
    at = next(i for i, b in enumerate(blocks) if int.from_bytes(b[4:6], "little") & 0x1FFF == 4006)
    no_z = bytearray(blocks[at + 2 * 2])  # the third epoch's PVTCartesian (after a DOP each)
    no_z[32:40] = np.float64(DNU).tobytes()  # Z: after the header, TOW, WNc, Mode, Error, X, Y
    blocks[at + 2 * 2] = revised(bytes(no_z), 2)
    log = read_sbf(write_sbf(tmp_path / "no_z.sbf", blocks), "no_z.sbf")
    assert np.isnan(log.channels["lat"][2]) and np.isfinite(log.channels["lat"]).sum() == 4
    assert "5 epochs (PVTCartesian), 4 with a fix" in log.notes[0]
    from pysbf2 import SBFMessage

    week, seconds = divmod(GPS_S, 604_800.0)
    off = SBFMessage(
        "PVTCartesian",
        revno=2,
        TOW=int(seconds * 1000),
        WNc=int(week),
        Type=1,
        X=1000.0,
        Y=1000.0,
        Z=1000.0,
        Undulation=48.0,
        NrSV=9,
        HAccuracy=NO_H_ACCURACY,
    )
    blocks = [dop(GPS_S - 1), revised(off.serialize(), 2)]
    with pytest.raises(InputError) as err:
        read_sbf(write_sbf(tmp_path / "off.sbf", blocks), "off.sbf")
    (problem,) = err.value.problems
    assert problem.row == 2 and problem.column == "PVTCartesian X, Y, Z"
    assert problem.expected == "a position within 100 km of the WGS84 ellipsoid"
    assert problem.found.startswith("6355.8 km below it (X, Y, Z = 1000.000, 1000.000, 1000")
    assert problem.found.endswith("m; the block at byte 32)")

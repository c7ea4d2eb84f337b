"""A u-blox receiver's UBX log beside a drive's stream CSVs (rwhonet.data.ubx).

The logs are written by pyubx2 (tests/support/ubx.py), not by the reader's code, and the
reader's values are compared with what pyubx2 reads back from the same bytes."""

from __future__ import annotations

import io

import numpy as np
import pytest
from pyubx2 import UBX_PROTOCOL, UBXReader

from rwhonet.data import canonical as c
from rwhonet.data.streamcsv import read_stream_csvs
from rwhonet.data.streams import resample
from rwhonet.data.ubx import is_ubx_name, read_ubx
from rwhonet.errors import InputError
from support.multirate import receiver_drive, receiver_labels
from support.ubx import (
    LEAP_S,
    itow_ms,
    nav_pvt,
    other_messages,
    u6_messages,
    ubx_messages,
    write_ubx,
)

DAY_S = 1_552_262_400.0  # 2019-03-11 00:00:00 UTC
T0 = DAY_S + 45_000.0


def _folder(tmp_path, gnss_csv: bool):
    """The drive's wheels.csv (and its gnss.csv where ``gnss_csv``) in ``tmp_path``."""
    from rwhonet.sim.streams import StreamTables, write_stream_csvs

    tables, _ = receiver_drive()
    keep = tables if gnss_csv else StreamTables(tables.wheels, tables.gnss.iloc[:0])
    return write_stream_csvs(keep, tmp_path)


def _pyubx2(data: bytes) -> list:
    """The NAV-PVT messages pyubx2 reads from a log's bytes."""
    reader = UBXReader(io.BytesIO(data), protfilter=UBX_PROTOCOL)
    return [m for _, m in reader if m.identity == "NAV-PVT"]


def test_names():
    assert is_ubx_name("gps.ubx") and is_ubx_name("GPS.UBX.gz")
    assert not is_ubx_name("gps.nmea") and not is_ubx_name("ubx.bin")


def test_the_reader_reads_what_pyubx2_reads(tmp_path):
    """A receiver's log of 1199 epochs (NAV-TIMEUTC and NAV-DOP before each NAV-PVT, an
    NMEA sentence line between, one NAV-PVT with a byte lost, one written twice, the last
    cut short): every epoch kept has the values pyubx2 reads from the clean log, scaled to
    SI; the rest is passed over and counted."""
    tables, _ = receiver_drive()
    g = tables.gnss
    t = DAY_S + g[c.T_S].to_numpy()
    messages = ubx_messages(g, t)
    clean = b"".join(messages)
    expected = _pyubx2(clean)
    assert len(expected) == len(g)
    dirty = list(messages)
    dirty[10] = b"$GPTXT,01,01,02,ANTSTATUS=OK*3B\r\n" + dirty[10]
    broken = bytearray(dirty[500])
    broken[-40] ^= 0x10  # a bit flipped in the NAV-PVT's payload
    dirty[500] = bytes(broken)
    dirty.insert(701, dirty[700][-100:])  # a NAV-PVT written again
    dirty[-1] = dirty[-1][:-30]
    log = read_ubx(write_ubx(tmp_path / "gps.ubx", dirty), "gps.ubx")
    kept = [i for i in range(len(g)) if i not in (500, len(g) - 1)]
    assert log.rows.size == len(kept)
    want = {
        "lat": [expected[i].lat for i in kept],
        "lon": [expected[i].lon for i in kept],
        "n_sats": [expected[i].numSV for i in kept],
        "height": [expected[i].hMSL / 1000.0 for i in kept],
        "speed_gnss": [expected[i].gSpeed / 1000.0 for i in kept],
        "heading": [expected[i].headMot for i in kept],
    }
    for key, values in want.items():
        np.testing.assert_allclose(log.channels[key], values, rtol=0, atol=1e-9, err_msg=key)
    # placed by iTOW: the UTC times written, to the ms iTOW holds
    np.testing.assert_allclose(log.day_s + log.tod_s, t[kept], rtol=0, atol=5e-4)
    assert log.rows[0] == 3 and log.rows[1] == 6  # the 3rd message: after TIMEUTC and DOP
    said = " ".join(log.notes)
    assert "a UBX log: 1197 epochs (NAV-PVT), 1197 with a fix" in said
    assert "other messages (NAV-DOP 1199, NAV-TIMEUTC 1199)" in said
    assert "1 NMEA sentence(s)" in said
    assert "1 NAV-PVT message(s) with a checksum that does not match (first at byte " in said
    assert "a NAV-PVT message cut short at the log's end" in said
    # the copy after the 701st epoch's three messages, less the one with the lost byte
    assert "1 NAV-PVT message(s) of an epoch already given (first message 2103)" in said
    assert "checksum" in log.dropped and "already given" in log.dropped
    assert "NAV-DOP" not in log.dropped  # what a receiver writes besides: no problem


@pytest.mark.parametrize(
    ("kw", "fix"),
    [
        ({}, True),
        ({"fix_type": 2}, True),
        ({"fix_type": 4}, True),  # GNSS with the receiver's dead reckoning
        ({"fix_type": 1}, False),  # dead reckoning only
        ({"fix_type": 5}, False),  # time only
        ({"fix_ok": 0}, False),
        ({"invalid_llh": 1}, False),
    ],
)
def test_what_is_a_fix(tmp_path, kw, fix):
    """gnssFixOK, fixType 2, 3 or 4 and a valid llh make a fix; otherwise the epoch is
    kept without a position, speed or course."""
    msgs = [nav_pvt(T0, 52.4, -1.5, speed_m_s=10.0, course_deg=90.0, **kw)]
    log = read_ubx(write_ubx(tmp_path / "a.ubx", msgs), "a.ubx")
    for key in ("lat", "lon", "speed_gnss", "heading"):
        assert np.isfinite(log.channels[key][0]) == fix, key
    assert log.channels["n_sats"][0] == 12


def test_an_84_byte_nav_pvt_of_a_u_blox_7_is_read(tmp_path):
    """u-blox 7 (protocol 14) writes NAV-PVT in 84 bytes, without flags3 and after."""
    full = nav_pvt(T0, 52.4, -1.5, invalid_llh=1)  # flags3 set: not in an 84-byte message
    body = bytearray(full[2:6] + full[6 : 6 + 84])
    body[2:4] = (84).to_bytes(2, "little")
    a = b = 0
    for x in body:
        a = (a + x) & 0xFF
        b = (b + a) & 0xFF
    log = read_ubx(write_ubx(tmp_path / "a.ubx", [b"\xb5\x62" + bytes(body) + bytes([a, b])]), "a")
    assert log.channels["lat"][0] == pytest.approx(52.4, abs=1e-7)


def test_a_cold_start_before_the_leap_seconds_and_the_week_s_end(tmp_path):
    """The receiver's first epochs before it knew the leap seconds (its UTC 2 s off, not
    fully resolved) and a drive across the GPS week's end (iTOW back to 0): every epoch is
    placed by iTOW, on the UTC of the resolved epochs."""
    sunday = 1_552_176_000.0 - LEAP_S  # GPS week's end 2019-03-10 00:00:00 GPS, in UTC
    t = sunday - 5.0 + 0.2 * np.arange(50)
    msgs = [_wrong_utc(x, 2.0) if i < 10 else nav_pvt(x, 52.4, -1.5) for i, x in enumerate(t)]
    log = read_ubx(write_ubx(tmp_path / "a.ubx", msgs), "a.ubx")
    np.testing.assert_allclose(log.day_s + log.tod_s, t, rtol=0, atol=5e-4)
    said = " ".join(log.notes)
    assert "fully resolved" in said and "may be off" not in said
    assert "GPS time of week passed the week's end before message(s) 26" in said


def _wrong_utc(t: float, off_s: float) -> bytes:
    """A NAV-PVT whose iTOW is ``t``'s and whose UTC fields are ``off_s`` wrong, not fully
    resolved (the receiver's default leap seconds)."""
    from pyubx2 import UBXMessage

    good = UBXReader.parse(nav_pvt(t + off_s, 52.4, -1.5, valid=(1, 1, 0)))
    fields = {k: v for k, v in vars(good).items() if not k.startswith("_")}
    fields["iTOW"] = itow_ms(t)
    return UBXMessage("NAV", "NAV-PVT", 0, **fields).serialize()


def test_utc_never_resolved_or_never_valid(tmp_path):
    t = T0 + 0.1 * np.arange(20)
    log = read_ubx(
        write_ubx(tmp_path / "a.ubx", [nav_pvt(x, 52.4, -1.5, valid=(1, 1, 0)) for x in t]), "a"
    )
    np.testing.assert_allclose(log.day_s + log.tod_s, t, rtol=0, atol=5e-4)
    assert "may be off by whole (leap) seconds" in " ".join(log.notes)
    invalid = [nav_pvt(x, 52.4, -1.5, valid=(0, 0, 0)) for x in t]
    with pytest.raises(InputError) as err:
        read_ubx(write_ubx(tmp_path / "b.ubx", invalid), "b.ubx")
    said = str(err.value)
    assert "b.ubx, column 'NAV-PVT valid'" in said and "none of 20 NAV-PVT epochs" in said


def test_a_log_without_nav_pvt_is_refused_naming_what_it_holds(tmp_path):
    """Neither NAV-PVT nor NAV-POSLLH nor NMEA sentences: refused, naming what the log holds
    and how to enable NAV-PVT."""
    path = write_ubx(tmp_path / "gps.ubx", [other_messages(1000 * i) for i in range(3)])
    with pytest.raises(InputError) as err:
        read_ubx(path, "gps.ubx")
    said = str(err.value)
    assert "expected UBX-NAV-PVT messages (class 0x01, id 0x07)" in said
    assert "found other messages (NAV-DOP 3, NAV-TIMEUTC 3)\n" in said
    assert "CFG-MSGOUT-UBX_NAV_PVT" in said
    with pytest.raises(InputError, match="found no UBX message"):
        read_ubx(write_ubx(tmp_path / "e.ubx", [b""]), "e.ubx")


def test_the_ubx_log_gives_the_labels_of_the_csv_fixes(tmp_path):
    """wheels.csv on the time of day and the receiver's fixes as gps.ubx: the seconds and
    labels of the same fixes in gnss.csv, within NAV-PVT's 1e-7 degree (1.1 cm a
    coordinate: 2 cm a second's displacement)."""
    tables, _ = receiver_drive()
    g = tables.gnss
    ref, _ = receiver_labels(list(_folder(tmp_path / "csv", True).values()))
    files = list(_folder(tmp_path / "ubx", False).values())
    files = [f for f in files if f.name != "gnss.csv"]
    files.append(write_ubx(tmp_path / "ubx" / "gps.ubx", ubx_messages(g, DAY_S + g[c.T_S])))
    got, streams = receiver_labels(files)
    assert len(got) == len(ref) > 100
    np.testing.assert_allclose(got["t_s"], ref["t_s"], rtol=0, atol=1e-3)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=0.02, err_msg=q)
    gnss = next(s for s in streams.streams if s.name == "gps.ubx")
    assert gnss.sources[c.LAT_DEG] == "NAV-PVT lat"
    np.testing.assert_allclose(gnss.channels[c.N_SATS], g[c.N_SATS])


def test_beside_the_receiver_s_nmea_log_the_ubx_log_is_read(tmp_path):
    """A logger that kept both of the receiver's outputs: the UBX log is read, the NMEA
    log left out, and a note says so."""
    from support.nmea import nmea_lines, write_nmea

    tables, _ = receiver_drive()
    g = tables.gnss
    folder = tmp_path / "both"
    files = [f for f in _folder(folder, False).values() if f.name != "gnss.csv"]
    files.append(write_ubx(folder / "gps.ubx", ubx_messages(g, DAY_S + g[c.T_S])))
    lines = nmea_lines(g.assign(**{c.LAT_DEG: g[c.LAT_DEG] + 1.0}), DAY_S + g[c.T_S])
    files.append(write_nmea(folder / "gps.nmea", lines))  # another place: must not be read
    got, streams = receiver_labels(files)
    ubx_only, _ = receiver_labels([f for f in files if f.name != "gps.nmea"])
    np.testing.assert_array_equal(got["disp_gnss_m"], ubx_only["disp_gnss_m"])
    said = " ".join(streams.notes)
    assert "gps.nmea: NMEA log(s), left out: the fixes are the receiver's UBX log's (" in said


def test_the_benchmark_s_writer_writes_pyubx2_s_bytes():
    """support.ubx.pvt_log (numpy, for the benchmark's hours) against pyubx2's messages."""
    from support.ubx import pvt_log

    tables, _ = receiver_drive()
    g = tables.gnss
    t = DAY_S + g[c.T_S].to_numpy()
    assert pvt_log(g, t) == b"".join(ubx_messages(g, t, others=False))


def test_a_receiver_s_ubx_log_rotated_is_joined(tmp_path):
    """gps.ubx cut into three files between messages and given in no order: the one log's
    labels exactly. Cut inside a NAV-PVT (a rotation in mid-write): that epoch is lost, and
    the note says so; the rest is the one log's."""
    tables, _ = receiver_drive()
    g = tables.gnss
    messages = ubx_messages(g, DAY_S + g[c.T_S])
    wheels = [f for f in _folder(tmp_path / "w", False).values() if f.name == "wheels.csv"]
    one, _ = receiver_labels([*wheels, write_ubx(tmp_path / "one" / "gps.ubx", messages)])
    parts = [messages[:400], messages[400:777], messages[777:]]
    files = [write_ubx(tmp_path / "three" / f"gps_{k}.ubx", parts[k]) for k in (2, 0, 1)]
    three, streams = receiver_labels([*wheels, *files])
    for q in one.columns:
        np.testing.assert_array_equal(three[q], one[q], err_msg=q)
    assert "one stream split across 3 files, joined in time order" in " ".join(streams.notes)
    data = b"".join(messages)
    cut = sum(map(len, messages[:600])) - 50  # inside the 600th epoch's NAV-PVT
    files = [
        write_ubx(tmp_path / "mid" / "gps_b.ubx", [data[cut:]]),
        write_ubx(tmp_path / "mid" / "gps_a.ubx", [data[:cut]]),
    ]
    mid, streams = receiver_labels([*wheels, *files])
    assert "a NAV-PVT message cut short at the log's end" in " ".join(streams.changed)
    gnss = next(s for s in streams.streams if c.LAT_DEG in s.channels)
    assert gnss.channels[c.LAT_DEG].size == len(g) - 1
    np.testing.assert_allclose(mid["disp_gnss_m"], one["disp_gnss_m"], rtol=0, atol=0.05)


def test_the_real_minute_s_fixes_as_a_ubx_log(tmp_path):
    """The RAV4's wheel speeds in wheels.csv on the receiver's UTC (the boot clock put on
    UTC by the receiver's own clock fit), its recorded u-blox fixes as NAV-PVT messages
    (pyubx2, among NAV-TIMEUTC and NAV-DOP) in place of GGA and RMC sentences: the same 59
    seconds, their GNSS displacements within 2 cm (1e-7 degrees against ddmm.mmmmmm), the
    wheels' travel the same. Both logs' times are the NMEA writer's, to 0.01 s."""
    from support.realminute import minute_seconds, write_minute_nmea

    ref, _ = minute_seconds(tmp_path / "nmea", write_minute_nmea)
    got, said = minute_seconds(
        tmp_path / "ubx", lambda d, f, t: write_ubx(d / "gps.ubx", ubx_messages(f, t))
    )
    assert "NAV-PVT dates, on the stream files' UTC" in said
    assert len(got) == len(ref) == 59
    for q in ("t_s", "disp_wpm_m"):
        np.testing.assert_array_equal(got[q], ref[q], err_msg=q)
    for q in ("disp_gnss_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=0.02, err_msg=q)


@pytest.mark.parametrize(
    ("status", "clock"), [("NAV-SOL", "NAV-TIMEUTC"), ("NAV-STATUS", "NAV-TIMEGPS")]
)
def test_a_u_blox_6_s_messages_give_the_fixes_nav_pvt_gives(tmp_path, status, clock):
    """A u-blox 6 has no NAV-PVT: its NAV-POSLLH, the fix in NAV-SOL (or NAV-STATUS),
    NAV-VELNED and the time in NAV-TIMEUTC (or NAV-TIMEGPS's week less the leap seconds)
    give the positions and times of the NAV-PVT log of the same fixes exactly, the speed
    within VELNED's 1 cm/s; the satellites where NAV-SOL gives them."""
    tables, _ = receiver_drive()
    g = tables.gnss
    t = DAY_S + g[c.T_S].to_numpy()
    pvt = read_ubx(write_ubx(tmp_path / "pvt.ubx", ubx_messages(g, t)), "pvt.ubx")
    messages = u6_messages(g, t, status=status, clock=clock)
    log = read_ubx(write_ubx(tmp_path / "u6.ubx", messages), "u6.ubx")
    np.testing.assert_array_equal(log.day_s + log.tod_s, pvt.day_s + pvt.tod_s)
    for key in ("lat", "lon", "height", "heading"):
        np.testing.assert_array_equal(log.channels[key], pvt.channels[key], err_msg=key)
    np.testing.assert_allclose(log.channels["speed_gnss"], pvt.channels["speed_gnss"], atol=0.005)
    assert ("n_sats" in log.channels) == (status == "NAV-SOL")
    if status == "NAV-SOL":
        np.testing.assert_array_equal(log.channels["n_sats"], pvt.channels["n_sats"])
    said = " ".join(log.notes)
    assert "a UBX log: 1199 epochs (NAV-POSLLH, " in said and clock in said
    assert "1199 with a fix; placed by iTOW on the UTC of the epochs whose date" in said
    assert log.sources["lat"] == "NAV-POSLLH lat" and log.rows[0] == 1


def test_a_u_blox_6_s_fix_status_and_its_leap_seconds(tmp_path):
    """NAV-SOL's dead reckoning alone is no fix; a NAV-POSLLH with a byte lost is passed
    over, said; NAV-TIMEGPS without valid leap seconds places the epochs with a note;
    NAV-POSLLH without NAV-SOL or NAV-STATUS is refused."""
    t = T0 + 0.1 * np.arange(20)
    g = _fixes(20)
    dr = read_ubx(write_ubx(tmp_path / "dr.ubx", u6_messages(g, t, fix_type=1)), "dr")
    assert not np.isfinite(dr.channels["lat"]).any()
    messages = u6_messages(g, t)
    messages[5] = messages[5][:20] + bytes([messages[5][20] ^ 4]) + messages[5][21:]
    lost = read_ubx(write_ubx(tmp_path / "lost.ubx", messages), "lost")
    assert lost.rows.size == 19
    assert "passed over: 1 NAV-POSLLH message(s) with a checksum that does not match" in (
        " ".join(lost.notes)
    )
    messages = u6_messages(g, t, clock="NAV-TIMEGPS", leap_valid=0)
    log = read_ubx(write_ubx(tmp_path / "leap.ubx", messages), "leap")
    np.testing.assert_allclose(log.day_s + log.tod_s, t, rtol=0, atol=5e-4)
    assert "may be off by whole (leap) seconds" in " ".join(log.notes)
    posllh = [m[:36] for m in u6_messages(g, t)]  # each epoch's NAV-POSLLH alone
    with pytest.raises(InputError) as err:
        read_ubx(write_ubx(tmp_path / "pos.ubx", posllh), "pos.ubx")
    said = str(err.value)
    assert "NAV-POSLLH with NAV-SOL or NAV-STATUS (its fix)" in said
    assert "found other messages (NAV-POSLLH 20)" in said


def _fixes(n: int):
    import pandas as pd

    return pd.DataFrame(
        {
            c.LAT_DEG: 52.4 + 1e-5 * np.arange(n),
            c.LON_DEG: -1.5,
            c.N_SATS: 9.0,
            c.SPEED_GNSS_M_S: 1.1,
            c.HEADING_DEG: 0.0,
        }
    )


def test_a_ubx_log_beside_a_logger_s_own_clock_is_refused_saying_what_to_do(tmp_path):
    """The wheels on the logger's clock from its start (0 s on): a UBX log carries no
    logger stamp to place it by, and the refusal says so (not "stamp each sentence")."""
    from rwhonet.sim.streams import StreamTables, write_stream_csvs

    tables, _ = receiver_drive()
    g = tables.gnss
    t0 = float(tables.wheels[c.T_S].iloc[0])
    own = StreamTables(tables.wheels.assign(t_s=tables.wheels[c.T_S] - t0), g.iloc[:0])
    files = write_stream_csvs(own, tmp_path / "own")
    log = write_ubx(tmp_path / "own" / "gps.ubx", ubx_messages(g, DAY_S + g[c.T_S]))
    with pytest.raises(InputError) as err:
        receiver_labels([files["wheels"], log])
    said = str(err.value)
    assert "a UBX log (no logger stamps in it), and the stream files' time in 's'" in said
    assert "log the signal map.t in UTC, or give the receiver's NMEA log with the" in said


@pytest.mark.parametrize("among", [False, True])
def test_a_ubx_log_of_nmea_sentences_is_read_as_the_nmea_log(tmp_path, among):
    """u-center records whatever the receiver sends as .ubx, and a u-blox's factory output
    is NMEA alone: such a gps.ubx (its sentences alone, or each epoch's after binary
    NAV-TIMEUTC and NAV-DOP messages on the same line) gives the labels of the same
    sentences as gps.nmea, placed by their UTC times (bytes before a "$" are no stamp)."""
    from support.nmea import nmea_lines, write_nmea

    tables, _ = receiver_drive()
    g = tables.gnss
    t = DAY_S + np.round(g[c.T_S].to_numpy(), 2)
    lines = nmea_lines(g.assign(t_s=t - DAY_S), t)
    wheels = [f for f in _folder(tmp_path / "w", False).values() if f.name == "wheels.csv"]
    want, _ = receiver_labels([*wheels, write_nmea(tmp_path / "nmea" / "gps.nmea", lines)])
    body, epoch = [], 0
    for line in lines:
        head = b""
        if among and "GGA," in line:  # an epoch's first sentence
            head = other_messages(itow_ms(float(t[epoch])))
            epoch += 1
        body.append(head + line.encode() + b"\r\n")
    got, streams = receiver_labels([*wheels, write_ubx(tmp_path / "ubx" / "gps.ubx", body)])
    np.testing.assert_array_equal(got.to_numpy(), want.to_numpy())
    said = " ".join(streams.notes)
    assert "gps.ubx: a UBX log without NAV-PVT or NAV-POSLLH: its 3597 NMEA sentence(s)" in said
    assert ("besides them: NAV-DOP 1199, NAV-TIMEUTC 1199" in said) == among


def test_a_dead_reckoning_receiver_s_yaw_rate_comes_from_its_esf_ins(tmp_path):
    """A u-blox ADR receiver's log: NAV-PVT and, at 50 Hz, ESF-INS with the car's yaw rate
    (its z angular rate, z down: the negative). With the map's yaw_rate in no CSV, the log
    gives it: the grid's yaw rate is gyro.csv's within ESF-INS's 1e-3 deg/s, the labels
    the same (the gyro's times to the ms in both, as iTOW holds them). Without ESF-INS,
    the map's yaw_rate is refused naming the log."""
    from rwhonet.sim.streams import StreamTables, signal_map, write_stream_csvs
    from support.multirate import per_second, simulated_streams
    from support.ubx import esf_ins

    tables, radius = simulated_streams(120.0, 100.0, 10.0, gyro_hz=50.0)
    # the gyro's times to the ms, as ESF-INS's iTOW holds them, in gyro.csv too
    gyro = tables.gyro.assign(t_s=np.round(tables.gyro[c.T_S], 3))
    tables = StreamTables(tables.wheels, tables.gnss, gyro)
    g = tables.gnss
    smap = signal_map(gyro=True)
    files = write_stream_csvs(tables, tmp_path / "csv")
    ref = resample(read_stream_csvs(list(files.values()), smap, radius), nominal_radius_m=radius)
    pvt = ubx_messages(g, DAY_S + g[c.T_S].to_numpy())
    ins = esf_ins(DAY_S + gyro[c.T_S].to_numpy(), gyro[c.YAW_RATE_RAD_S].to_numpy())
    folder = [files["wheels"], write_ubx(tmp_path / "adr" / "gps.ubx", [*pvt, *ins])]
    streams = read_stream_csvs(folder, smap, radius)
    got = resample(streams, nominal_radius_m=radius)
    a, b = got.drive.columns, ref.drive.columns
    np.testing.assert_array_equal(a[c.T_S], b[c.T_S])
    step = np.deg2rad(1e-3)  # ESF-INS's resolution, which pyubx2 truncates to
    np.testing.assert_allclose(a[c.YAW_RATE_RAD_S], b[c.YAW_RATE_RAD_S], rtol=0, atol=step)
    ref_s, got_s = per_second(b, radius), per_second(a, radius)
    np.testing.assert_allclose(got_s["label_m"], ref_s["label_m"], rtol=0, atol=0.02)
    yaw = next(s for s in streams.streams if c.YAW_RATE_RAD_S in s.channels)
    assert yaw.name == "ESF-INS" and yaw.rows[0] == 3 * len(pvt) + 1  # after 3 an epoch
    assert f"{len(gyro)} yaw rates (ESF-INS zAngRate negated" in " ".join(streams.notes)
    only_pvt = [files["wheels"], write_ubx(tmp_path / "pvt" / "gps.ubx", pvt)]
    with pytest.raises(InputError) as err:
        read_stream_csvs(only_pvt, smap, radius)
    said = str(err.value)
    assert "UBX-ESF-INS z angular rate in its UBX log; found in neither" in said


def test_the_stated_accuracy_is_nav_pvt_s_hacc_in_metres(tmp_path):
    """NAV-PVT's hAcc (mm) is h_acc in metres, as pyubx2 reads it: 1234 mm a 1.234 m fix;
    an epoch without a fix keeps its own (250 m), which no screen takes (it has no fix)."""
    msgs = [
        nav_pvt(T0, 52.4, -1.5, h_acc_mm=1234),
        nav_pvt(T0 + 0.1, 52.4, -1.5, h_acc_mm=800),
        nav_pvt(T0 + 0.2, float("nan"), float("nan"), h_acc_mm=250_000),
    ]
    data = b"".join(msgs)
    log = read_ubx(write_ubx(tmp_path / "a.ubx", msgs), "a.ubx")
    np.testing.assert_array_equal(log.channels["h_acc"], [1.234, 0.8, 250.0])
    assert log.channels["h_acc"].dtype == np.float64
    np.testing.assert_allclose(
        log.channels["h_acc"], [m.hAcc / 1000.0 for m in _pyubx2(data)], rtol=0, atol=1e-12
    )
    assert log.sources["h_acc"] == "NAV-PVT hAcc"
    assert np.isnan(log.channels["lat"][2])


def test_a_u_blox_6_s_stated_accuracy_is_nav_posllh_s_hacc(tmp_path):
    """A u-blox 6's NAV-POSLLH hAcc (mm) is h_acc in metres, as NAV-PVT's."""
    t = T0 + 0.1 * np.arange(5)
    log = read_ubx(write_ubx(tmp_path / "u6.ubx", u6_messages(_fixes(5), t, h_acc_mm=1234)), "u6")
    np.testing.assert_array_equal(log.channels["h_acc"], np.full(5, 1.234))
    assert log.sources["h_acc"] == "NAV-POSLLH hAcc"


def test_the_ubx_log_s_stated_accuracy_reaches_the_drive(tmp_path):
    """A gps.ubx beside wheels.csv whose NAV-PVT hAcc each fix states: the GNSS stream's
    h_acc_m is it (NAV-PVT hAcc), and the resampled drive has an h_acc_m column, each
    row's within the accuracies stated either side of it."""
    from rwhonet.sim.streams import signal_map

    tables, radius = receiver_drive()
    g = tables.gnss
    g = g.assign(**{c.H_ACC_M: 1.0 + 0.001 * np.arange(len(g))})
    wheels = [f for f in _folder(tmp_path / "w", False).values() if f.name == "wheels.csv"]
    log = write_ubx(tmp_path / "ubx" / "gps.ubx", ubx_messages(g, DAY_S + g[c.T_S]))
    streams = read_stream_csvs([*wheels, log], signal_map(), radius)
    np.testing.assert_allclose(streams.gnss.channels[c.H_ACC_M], g[c.H_ACC_M], atol=1e-12)
    assert streams.gnss.sources[c.H_ACC_M] == "NAV-PVT hAcc"
    h = resample(streams, nominal_radius_m=radius).drive.columns[c.H_ACC_M]
    assert h.size > 1000 and np.isfinite(h).all()
    assert 1.0 <= h.min() and h.max() <= g[c.H_ACC_M].max() + 1e-9

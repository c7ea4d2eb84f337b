"""gpsd's JSON reports of a drive's fixes, laid out as ``gpspipe -w`` keeps them from gpsd
3.22 reading an NMEA receiver (tests/fixtures/gpsd holds gpsd's own): for each epoch a TPV
as its GGA comes (no speed or course yet) and a TPV with all of the epoch once its RMC
comes, and a SKY report each second."""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data import canonical as c

HEAD = (
    '{"class":"VERSION","release":"3.22","rev":"3.22","proto_major":3,"proto_minor":14}',
    '{"class":"WATCH","enable":true,"json":true,"nmea":false,"raw":0,"scaled":false}',
)


def iso(t_s: float) -> str:
    """gpsd's time: ISO 8601 UTC to the millisecond."""
    return datetime.fromtimestamp(round(t_s, 3), UTC).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"


def gpsd_lines(gnss: pd.DataFrame, utc_s: np.ndarray, device: str = "/dev/ttyACM0") -> list[str]:
    """The reports of ``gnss``'s fixes at ``utc_s`` (s since 1970)."""
    lat, lon = gnss[c.LAT_DEG].to_numpy(), gnss[c.LON_DEG].to_numpy()
    sats = gnss[c.N_SATS].to_numpy() if c.N_SATS in gnss else np.full(len(gnss), 9.0)
    lines = list(HEAD)
    for i, t in enumerate(utc_s):
        if i % 10 == 0:
            used = int(sats[i]) if np.isfinite(sats[i]) else 0
            lines.append(json.dumps({"class": "SKY", "device": device, "nSat": 12, "uSat": used}))
        base = {"class": "TPV", "device": device, "mode": 3, "time": iso(t)}
        base |= {"lat": round(float(lat[i]), 9), "lon": round(float(lon[i]), 9), "altMSL": 112.4}
        lines.append(json.dumps(base | {"eph": 17.1}))
        lines.append(json.dumps(base | {"track": 30.0, "speed": 10.0, "eph": 17.1}))
    return lines


def write_gpsd(path: Path, lines: list[str]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path

"""``rwhonet predict`` on every built-in drive of a profile, as it is and with each diagonal
pair of wheel columns exchanged: which the stream's checks refuse, and as what.

``predict`` tells the wheel columns on the rows as they come, trying the checks each time
the rows have grown by half, so it fits the diagonal gain on fewer pairs of seconds, and
more often, than validate on the whole drive: a bound that holds over whole drives could
be crossed at an early try. This runs the command itself (``rwhonet.cli.main.main``, in one
process), on the simulator's fleet written to a scratch folder, each drive for its own
car's radius and rear track (``--vehicle-file``), and prints per variant: refused as that
diagonal pair, refused by another check (with the check's words), and passed. Nothing is
written outside the scratch folder. Needs the registered model (after ``make run``).

Usage: python benchmarks/diagonal_predict.py [--model models:/whonet-G/latest] [profile ...]
       (default profiles: paper, ci)
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import tempfile
from pathlib import Path

import pandas as pd

from rwhonet.cli.main import main as rwhonet
from rwhonet.config import load_params
from rwhonet.sim import simulate_fleet

# the IO-VNBD header's wheel columns, each diagonal pair
COLUMNS = {
    "fl": " Wheel Speed Front Left (rad/sec)",
    "fr": " Wheel Speed Front Right (rad/sec)",
    "rl": " Wheel Speed Rear Left (rad/sec)",
    "rr": " Wheel Speed Rear Right (rad/sec)",
}
VARIANTS = {
    "as_is": None,
    "front_left_for_rear_right": ("fl", "rr"),
    "front_right_for_rear_left": ("fr", "rl"),
}


def _predict(model: str, drive: Path, vehicle: Path, out: Path) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = rwhonet(
            ["predict", "--model", model, "--drive", str(drive), "--vehicle-file", str(vehicle)]
            + ["--output", str(out), "--quiet"]
        )
    return code, err.getvalue()


def profile_predict(profile: str, model: str) -> dict:
    """The verdicts on one profile's fleet (see the module docstring)."""
    params = load_params(overrides={"sim.profile": profile})
    tally = {
        name: {"refused_as_diagonal": 0, "refused_otherwise": [], "passed": 0} for name in VARIANTS
    }
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        summary = simulate_fleet(params, root / "sim")
        for d in summary["drives"]:
            vehicle = root / f"{d['vehicle']}.yaml"
            vehicle.write_text(
                f"nominal_radius_m: {params.nominal_radius_m(d['vehicle'])}\n"
                f"track_rear_m: {params.track_rear_m(d['vehicle'])}\n"
            )
            df = pd.read_csv(root / "sim" / d["role"] / f"{d['drive']}.csv")
            for name, pair in VARIANTS.items():
                drive = root / f"{d['drive']}.{name}.csv"
                if pair is not None:
                    a, b = (COLUMNS[k] for k in pair)
                    df = df.copy()
                    df[[a, b]] = df[[b, a]].to_numpy()
                df.to_csv(drive, index=False)
                code, said = _predict(model, drive, vehicle, root / "out.csv")
                if code == 0:
                    tally[name]["passed"] += 1
                elif "(a diagonal pair:" in said:
                    tally[name]["refused_as_diagonal"] += 1
                else:
                    first = next(
                        (line for line in said.splitlines() if "(validate's" in line), said
                    )
                    tally[name]["refused_otherwise"].append([d["drive"], first[-120:]])
                if pair is not None:  # the next variant starts from the drive as it is
                    df[[a, b]] = df[[b, a]].to_numpy()
                drive.unlink()
    return tally


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="models:/whonet-G/latest")
    ap.add_argument("profiles", nargs="*", default=["paper", "ci"])
    args = ap.parse_args()
    for profile in args.profiles:
        print(profile, json.dumps(profile_predict(profile, args.model)), flush=True)


if __name__ == "__main__":
    main()

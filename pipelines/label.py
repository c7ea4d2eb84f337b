"""DVC stage label: per-second samples, rear-radius calibration and the input scaler.

Reads data/interim/segments; writes data/processed/samples/, calibration.json and
scaler.json (docs/architecture.md, "Samples"). Usage: python pipelines/label.py
"""

import argparse
import time

from rwhonet import paths, stage
from rwhonet.config import load_params


def main() -> None:
    argparse.ArgumentParser(description=__doc__).parse_args()
    params = load_params()

    from rwhonet.features.samples import label

    start = time.perf_counter()
    summary = label(params, paths.SEGMENTS, paths.SAMPLES, paths.CALIBRATION, paths.SCALER)
    elapsed_s = time.perf_counter() - start
    print(
        f"rear radii r_rl = {summary['r_rl_m']:.5f} m, r_rr = {summary['r_rr_m']:.5f} m "
        f"({summary['calibration_role']}: {', '.join(summary['calibration_drives'])}); "
        f"WPM {summary['wpm_mode']}, scaler {summary['scaler']} (source_train)"
    )
    rows = 0
    for role, info in summary["roles"].items():
        rows += info["rows"]
        mean = info["label_mean_m"]
        print(
            f"  {role:<20} {info['segments']:>4} segments {info['seconds']:>8} seconds"
            + (f"  mean label {mean:+.3f} m" if mean is not None else "")
        )
    print(f"{rows:,} rows in {elapsed_s:.1f} s -> {paths.rel(paths.SAMPLES)}")


if __name__ == "__main__":
    stage.run(main)

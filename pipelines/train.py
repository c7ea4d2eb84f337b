"""DVC stages train_g / train_s: train G-WhONet (source vehicle) or S-WhONet (target vehicle).

Usage: python pipelines/train.py G|S
"""

import argparse

from rwhonet import paths, stage
from rwhonet.config import load_params


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("which", choices=["G", "S"])
    args = ap.parse_args()
    params = load_params()

    from rwhonet.experiment.train import train_model

    out = paths.MODEL_G if args.which == "G" else paths.MODEL_S
    rec, seconds = train_model(params, args.which, paths.SAMPLES, out)
    last = rec.history[-1] if rec.history else {}
    nan = float("nan")
    m = rec.metrics
    print(
        f"{rec.name}: {int(m['n_train_samples'])} training seconds from {int(m['n_drives'])} "
        f"drives, {params.train.epochs} epochs in {seconds:.1f} s "
        f"({m['n_train_samples'] * params.train.epochs / seconds:,.0f} samples/s); final train MAE "
        f"{last.get('train/loss', nan):.4f} m, val MAE {last.get('val/loss', nan):.4f} m "
        f"-> {paths.rel(out)}"
    )


if __name__ == "__main__":
    stage.run(main)

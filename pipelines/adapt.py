"""DVC stage adapt@m: R-WhONet = G-WhONet fine-tuned on each test drive's first m seconds.

Usage: python pipelines/adapt.py M
"""

import argparse

from rwhonet import paths, stage
from rwhonet.config import load_params


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("m", type=int, help="adaptation length in seconds (a point of adapt.m_grid)")
    args = ap.parse_args()
    params = load_params()

    from rwhonet.experiment.adapt import adapt_m, r_dir

    rec, seconds = adapt_m(params, args.m, paths.SAMPLES, paths.MODEL_G, r_dir(args.m))
    m = rec.metrics
    print(
        f"{rec.name}: {len(rec.children)} drives, trainable {int(m['n_trainable_params'])}"
        f" of {int(m['n_total_params'])} parameters ({params.adapt.trainable}), "
        f"{params.adapt.epochs} epochs, {seconds:.1f} s of fitting "
        f"-> {paths.rel(r_dir(args.m))}"
    )


if __name__ == "__main__":
    stage.run(main)

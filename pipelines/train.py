"""DVC stages train_g / train_s: train G-WhONet (source vehicle) or S-WhONet (target vehicle).

Usage: python pipelines/train.py G|S --seed SEED
"""

import argparse

from rwhonet import runner
from rwhonet.stages import train

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("which", choices=["G", "S"])
    ap.add_argument("--seed", type=int, required=True, help="training seed (one of params seeds)")
    args = ap.parse_args()
    which, seed = args.which, args.seed
    runner.run(f"train_{which.lower()}", lambda params: train.main(params, which, seed))

"""DVC stage train: G-WhONet (source vehicle) and S-WhONet (target vehicle) at every seed.

Usage: python pipelines/train.py [G|S] [--seed SEED]
(the stage runs it bare; a model or a seed alone is for a run by hand)
"""

import argparse

from rwhonet import runner
from rwhonet.stages import train

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("which", nargs="?", choices=["G", "S"], help="only this model")
    ap.add_argument("--seed", type=int, help="only this seed (one of params seeds)")
    args = ap.parse_args()
    runner.run_script("train", lambda params: train.main(params, args.which, args.seed))

"""DVC stages train_g / train_s: train G-WhONet (source vehicle) or S-WhONet (target vehicle).

Usage: python pipelines/train.py G|S
"""

import argparse

from rwhonet import stage
from rwhonet.stages import train

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("which", choices=["G", "S"])
    which = ap.parse_args().which
    stage.run(f"train_{which.lower()}", lambda params: train.main(params, which))

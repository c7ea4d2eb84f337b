"""DVC stage adapt: R-WhONet = G-WhONet fine-tuned on each test drive's first m s, every m.

Usage: python pipelines/adapt.py --seed SEED
"""

import argparse

from rwhonet import runner
from rwhonet.stages import adapt

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seed", type=int, required=True, help="training seed (one of params seeds)")
    seed = ap.parse_args().seed
    runner.run_script("adapt", lambda params: adapt.main(params, seed))

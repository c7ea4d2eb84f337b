"""DVC stage simulate: params.yaml `sim` -> simulated drives in the IO-VNBD layout (data/sim)."""

from rwhonet import runner
from rwhonet.stages import simulate

if __name__ == "__main__":
    runner.run_script("simulate", simulate.main)

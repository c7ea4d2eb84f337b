"""DVC stage label: per-second samples, rear-radius calibration and the input scaler."""

from rwhonet import runner
from rwhonet.stages import label

if __name__ == "__main__":
    runner.run_script("label", label.main)

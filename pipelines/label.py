"""DVC stage label: per-second samples, rear-radius calibration and the input scaler."""

from rwhonet import stage
from rwhonet.stages import label

if __name__ == "__main__":
    stage.run("label", label.main)

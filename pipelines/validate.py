"""DVC stage validate: pandera schema + GNSS-quality policy -> valid segments and a report."""

from rwhonet import runner
from rwhonet.stages import validate

if __name__ == "__main__":
    runner.run_script("validate", validate.main)

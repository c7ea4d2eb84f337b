"""DVC stage validate: pandera schema + GNSS-quality policy -> valid segments and a report."""

from rwhonet import stage
from rwhonet.stages import validate

if __name__ == "__main__":
    stage.run("validate", validate.main)

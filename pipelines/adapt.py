"""DVC stage adapt: R-WhONet = G-WhONet fine-tuned on each test drive's first m s, every m."""

from rwhonet import stage
from rwhonet.stages import adapt

if __name__ == "__main__":
    stage.run("adapt", adapt.main)

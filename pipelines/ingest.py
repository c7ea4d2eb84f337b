"""DVC stage ingest: raw drive files -> canonical Arrow drives + manifest."""

from rwhonet import runner
from rwhonet.stages import ingest

if __name__ == "__main__":
    runner.run_script("ingest", ingest.main)

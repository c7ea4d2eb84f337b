"""DVC stage ingest: raw drive files -> canonical Parquet drives + manifest."""

from rwhonet import stage
from rwhonet.stages import ingest

if __name__ == "__main__":
    stage.run("ingest", ingest.main)

"""DVC stage ingest: raw drive files -> canonical Parquet drives + manifest (data/interim/drives).

Reads the drives that params.yaml `data.roles` lists (IO-VNBD layout or a column
map), in SI units with canonical names. Usage: python pipelines/ingest.py
"""

import time

from rwhonet import paths, stage
from rwhonet.config import load_params


def main() -> None:
    params = load_params()

    from rwhonet.data.ingest import ingest, summary_table

    start = time.perf_counter()
    manifest = ingest(params, paths.DRIVES)
    seconds = time.perf_counter() - start
    rows = sum(d["n_rows"] for d in manifest["drives"])
    print(summary_table(manifest))
    cal = manifest["calibration"]
    print(f"calibration: {', '.join(cal['drives'])} ({cal.get('note', cal['role'])})")
    print(
        f"{rows} rows in {seconds:.2f} s ({rows / max(seconds, 1e-9) / 1e6:.2f} M rows/s) "
        f"-> {paths.rel(paths.DRIVES)}"
    )


if __name__ == "__main__":
    stage.run(main)

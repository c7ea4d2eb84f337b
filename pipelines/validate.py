"""DVC stage validate: pandera schema + GNSS-quality policy -> valid segments and a report.

Writes data/interim/segments/<drive>__s<k>.parquet + manifest.json and
reports/validation.json (every cut, its rule and why). Any invalid input fails
the stage with one report of every problem and writes nothing.
Usage: python pipelines/validate.py
"""

from rwhonet import paths, stage
from rwhonet.config import load_params


def main() -> None:
    params = load_params()

    from rwhonet.data.validate import summary_table, validate

    report = validate(params, paths.DRIVES, paths.SEGMENTS, paths.VALIDATION_REPORT)
    print(summary_table(report))
    print(f"-> {paths.rel(paths.SEGMENTS)}, {paths.rel(paths.VALIDATION_REPORT)}")


if __name__ == "__main__":
    stage.run(main)

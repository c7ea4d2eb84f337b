"""DVC stage evaluate: CRSE/CTE of WPM, G, S and R (every m) on the test drives; MLflow runs."""

from rwhonet import paths, stage
from rwhonet.config import load_params


def main() -> None:
    params = load_params()

    from rwhonet.experiment import evaluate as ev
    from rwhonet.tracking.store import log_execution, resolve_tracking_uri

    frame = ev.collect_predictions(
        params, paths.SAMPLES, paths.MODEL_G, paths.MODEL_S, paths.MODELS_R
    )
    result = ev.evaluate(params, frame)
    ev.write_outputs(
        params,
        result,
        eval_path=paths.EVAL_JSON,
        tables_path=paths.TABLES_MD,
        predictions_dir=paths.PREDICTIONS,
        plots_dir=paths.PLOTS,
        provenance=ev.provenance_line(params),
    )
    records = ev.run_records(params, result, paths.MODEL_G, paths.MODEL_S, paths.MODELS_R)
    parent = ev.evaluation_record(
        params, result, [paths.EVAL_JSON, paths.TABLES_MD, *sorted(paths.PLOTS.glob("*.csv"))]
    )
    uri = resolve_tracking_uri(params.tracking.tracking_uri)
    run_id = log_execution(
        records, uri=uri, experiment=params.tracking.experiment, execution=parent
    )

    print((paths.TABLES_MD.read_text(encoding="utf-8").split("## Table 2")[0]).strip())
    print(
        f"\nMLflow: experiment '{params.tracking.experiment}', parent run {run_id} "
        f"({len(records)} child runs) in {uri}; `make ui` to compare."
    )


if __name__ == "__main__":
    stage.run(main)

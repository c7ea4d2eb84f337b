"""The DVC plots' data of an evaluation: one wide table per ``reports/plots/`` file.

``dvc.yaml``'s ``plots`` section draws them: the CRSE and CTE evolution over an
outage's seconds (per outage length), mean CRSE
against m (every recipe, WPM-m; G, S and WPM flat), and the longest outage's
CRSE by the minute of the drive a window starts at. Read from the evaluation
package's typed result (:class:`rwhonet.evaluation.result.Evaluation`), never
recomputed; the evaluate stage writes them.
"""

from __future__ import annotations

import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.contracts import recipe_model
from rwhonet.evaluation.result import Evaluation
from rwhonet.evaluation.scoring import CURVE_MODELS


def plot_frames(ev: Evaluation, params: Params) -> dict[str, pd.DataFrame]:
    """Every plot file's table by its name under ``reports/plots/``.

    ``<crse|cte>_evolution_<L>s.csv`` (second of the outage; WPM, G, S, R),
    ``m_grid.csv`` (:func:`m_grid_plot`) and ``crse_over_time.csv`` (minute of the
    drive a window of the longest outage starts at; one column per model, those at
    the chosen m without their ``@m``, so the columns stay the same when m changes).
    """
    out = {}
    for L, g in ev.evolution.groupby("outage_s"):
        for metric in ("crse", "cte"):
            wide = g.pivot(index="second", columns="model", values=f"{metric}_m")
            out[f"{metric}_evolution_{L}s.csv"] = wide[list(CURVE_MODELS)].reset_index()
    out["m_grid.csv"] = m_grid_plot(ev.summary, params)
    L, at_m = max(params.evaluate.outages_s), f"@{ev.choice.m}"
    t = ev.over_time[ev.over_time["outage_s"] == L]
    t = t.assign(from_min=t["from_s"] / 60.0, model=t["model"].str.removesuffix(at_m))
    over_time = t.pivot(index="from_min", columns="model", values="crse").reset_index()
    out["crse_over_time.csv"] = over_time
    return out


def m_grid_plot(summary: pd.DataFrame, params: Params) -> pd.DataFrame:
    """Mean CRSE of the longest outage against m: every recipe and WPM-m; G, S, WPM flat."""
    L = max(params.evaluate.outages_s)
    rows = summary[
        (summary["role"] == k.TARGET_TEST)
        & (summary["drive"] == "all")
        & (summary["outage_s"] == L)
    ].set_index("model")["crse_mean"]
    grid = params.adapt.m_grid
    lines = {r: [rows[recipe_model(r, m)] for m in grid] for r in params.adapt.recipes}
    lines["WPM-m"] = [rows[f"WPM-m@{m}"] for m in grid]
    return pd.DataFrame({"m": grid, **lines, **{name: rows[name] for name in ("G", "S", "WPM")}})

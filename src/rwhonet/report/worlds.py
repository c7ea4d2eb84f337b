"""Every headline claim, checked world by world: the matrix of simulated worlds in docs/results.md.

A claim that holds in one simulated world may not hold in another (issue 16): a
target car with larger tyres, or a consumer GNSS receiver whose label noise is
several times the VBOX's, changes what recalibration can do. ``make worlds``
runs the pipeline once per world (``build/worlds/<world>/``); this module reads
each world's ``metrics/eval.json`` and ``params.yaml`` and marks every claim as
holding or not, with the numbers and intervals it rests on. It reads only what
the evaluation wrote (:mod:`rwhonet.evaluation.result`); nothing is recomputed.

Claims are data (:data:`CLAIMS`): each is a sentence the docs make and a
function from one world's evaluation to a :class:`Verdict`. The thresholds are
the issue's acceptance bounds (5 % of min(G, S), no worse than G at any m) or
say what "about the same" means; none is tuned to a world.

Run ``python -m rwhonet.report.worlds build/worlds/<a> build/worlds/<b> ...
--results docs/results.md`` to rewrite the section between
``<!-- worlds:begin -->`` and ``<!-- worlds:end -->`` of docs/results.md.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import astuple, dataclass
from pathlib import Path
from typing import Any

import yaml

from rwhonet.evaluation.intervals import COVER_BANDS, band_chance

BEGIN, END = "<!-- worlds:begin -->", "<!-- worlds:end -->"
NEAR = 0.05  # "within 5 %": the acceptance bound for R and continuous


@dataclass(frozen=True)
class World:
    """One world's evaluation.

    Attributes:
        name: the world (its sim profile, or the folder's name).
        ev: its ``metrics/eval.json`` content.
        params: its ``params.yaml`` content (what the user set).
        folder: where it ran (its MLflow store is ``<folder>/mlruns``).
    """

    name: str
    ev: dict[str, Any]
    params: dict[str, Any]
    folder: str = ""

    @property
    def longest(self) -> str:
        """The longest outage's key in eval.json (``"180s"``)."""
        return max(self.ev["overall"]["WPM"], key=lambda k: int(k.removesuffix("s")))

    def crse(self, model: str) -> tuple[float, float] | None:
        """Mean CRSE at the longest outage over all target test windows, and its ci95."""
        cell = self.ev["overall"].get(model, {}).get(self.longest)
        if not cell or cell.get("crse_mean") is None:
            return None
        return float(cell["crse_mean"]), float(cell.get("crse_ci95") or 0.0)


@dataclass(frozen=True)
class Verdict:
    """Whether a claim holds in one world (None: the world lacks what it needs) and why."""

    holds: bool | None
    evidence: str


def _pm(value: float, ci: float | None, digits: int = 2) -> str:
    if ci is not None and math.isfinite(ci) and ci > 0:
        return f"{value:.{digits}f} ± {ci:.{digits}f}"
    return f"{value:.{digits}f}"


def _chosen(w: World) -> tuple[str, int | None]:
    return str(w.ev["recipe"]), w.ev.get("chosen_m")


def recalibration_helps(w: World) -> Verdict:
    """R − G at the longest outage, per seed then averaged: below 0 with its interval."""
    d = w.ev.get("differences", {}).get("R - G", {}).get(w.longest)
    if not d:
        return Verdict(None, "no R − G difference")
    upper = d["crse_mean"] + (d.get("crse_ci95") or 0.0)
    return Verdict(
        upper < 0,
        f"R − G = {_pm(d['crse_mean'], d.get('crse_ci95') or 0.0)} m "
        f"({100 * d.get('crse_rel', math.nan):+.0f} %)",
    )


def r_near_best(w: World) -> Verdict:
    """R (the pipeline's choice) within 5 % of min(G, S) or better, on the mean."""
    r, g, s = w.crse("R"), w.crse("G"), w.crse("S")
    if not (r and g and s):
        return Verdict(None, "R, G or S missing")
    best = min(g[0], s[0])
    recipe, m = _chosen(w)
    at = f"{recipe}@{m}" if m is not None else recipe
    return Verdict(
        r[0] <= (1 + NEAR) * best,
        f"R ({at}) {_pm(*r)}, G {_pm(*g)}, S {_pm(*s)} m: R/min(G, S) = {r[0] / best:.2f}",
    )


def default_no_harm(w: World) -> Verdict:
    """The recipe ``auto`` falls back to (``rwhonet recalibrate``'s default) vs G at every m."""
    fallback = w.params.get("adapt", {}).get("fallback", {}).get("recipe")
    g = w.crse("G")
    if not fallback or not g:
        return Verdict(None, "no fallback recipe or no G")
    cells = {m: w.crse(f"R[{fallback}]@{m}") for m in w.params.get("adapt", {}).get("m_grid", [])}
    cells = {m: c for m, c in cells.items() if c}
    if not cells:
        return Verdict(None, f"no R[{fallback}]@m in eval.json")
    worst = max(cells, key=lambda m: cells[m][0])
    return Verdict(
        all(c[0] <= g[0] for c in cells.values()),
        f"`{fallback}`: worst m = {worst} s, {_pm(*cells[worst])} m against G {_pm(*g)} "
        f"({cells[worst][0] / g[0] - 1:+.0%}); at m = {min(cells)} s {_pm(*cells[min(cells)])}",
    )


def continuous_near_s(w: World) -> Verdict:
    """Continuous recalibration within 5 % of S or better, on the mean."""
    c, s = w.crse("R[continuous]"), w.crse("S")
    if not (c and s):
        return Verdict(None, "no continuous recipe or no S")
    return Verdict(
        c[0] <= (1 + NEAR) * s[0],
        f"continuous {_pm(*c)} m, S {_pm(*s)} m: ratio {c[0] / s[0]:.2f}",
    )


def network_beyond_radius(w: World) -> Verdict:
    """The network adds nothing measurable beyond one radius: R − WPM-m@m's interval holds 0."""
    _, m = _chosen(w)
    key = next((k for k in w.ev.get("differences", {}) if k.startswith("R - WPM-m@")), None)
    d = w.ev["differences"][key].get(w.longest) if key else None
    if not d:
        return Verdict(None, f"no R − WPM-m difference (chosen m {m})")
    ci = d.get("crse_ci95") or 0.0
    return Verdict(
        abs(d["crse_mean"]) <= ci,
        f"{key.replace(' - ', ' − ')} = {_pm(d['crse_mean'], ci)} m",
    )


def g_like_wpm(w: World) -> Verdict:
    """G barely changes the WPM on the new car: its gain over the WPM within ±5 %."""
    gain = w.ev.get("gains", {}).get("G", {}).get("WPM", {}).get(w.longest)
    if not gain:
        return Verdict(None, "no gain of G over the WPM")
    return Verdict(
        abs(gain["gain"]) <= NEAR,
        f"1 − G/WPM = {100 * gain['gain']:+.1f} ± {100 * (gain.get('gain_ci95') or 0):.1f} %",
    )


def ten_seconds_harm(w: World) -> Verdict:
    """At m = 10 s some recipe is worse than G on average over the drives."""
    m10 = min(w.params.get("adapt", {}).get("m_grid", [10]))
    worse = sorted(
        model.split("]")[0].removeprefix("R[")
        for model, by_outage in w.ev.get("no_harm", {}).items()
        if model.endswith(f"]@{m10}") and by_outage.get(w.longest, {}).get("worse_on_average")
    )
    return Verdict(
        bool(worse),
        f"worse than G at m = {m10} s: " + (", ".join(worse) if worse else "none"),
    )


POSITION_PCT = 2.0  # issue 17: the fused filter's mean error at the longest outage, % of distance
SAME_POSITION_PCT = 0.1  # "does not change the position": within 0.1 % of the distance


def _fused(w: World) -> dict[str, Any] | None:
    """The navigation filter's controls (fused, gyro, wheels, GNSS distance) by outage."""
    rows = w.ev.get("position_controls", {}).get("rows")
    return rows or None


def fused_within_2pct(w: World) -> Verdict:
    """The fused filter on R-WhONet's distances: mean end-of-outage error ≤ 2 % of distance."""
    rows = _fused(w)
    cell = rows.get("fused", {}).get(w.longest) if rows else None
    if not cell:
        return Verdict(None, "no navigation filter in eval.json")
    return Verdict(
        cell["pos_pct"] <= POSITION_PCT,
        f"fused, R-WhONet's distances: {_pm(cell['pos_mean'], cell['pos_mean_ci95'])} m, "
        f"{_pm(cell['pos_pct'], cell['pos_pct_ci95'])} % of the distance driven",
    )


def fused_beats_each_sensor(w: World) -> Verdict:
    """Fused better than the gyro alone and the wheels alone at the longest outage."""
    rows = _fused(w)
    if not rows or not all(k in rows for k in ("fused", "gyro", "wheels")):
        return Verdict(None, "no filter controls in eval.json")
    cells = {k: rows[k][w.longest] for k in ("fused", "gyro", "wheels")}
    pct = {k: c["pos_pct"] for k, c in cells.items()}

    def shown(k: str) -> str:  # three places, with the seeds' interval: a near tie shows
        return _pm(pct[k], cells[k].get("pos_pct_ci95"), 3)

    return Verdict(
        pct["fused"] < min(pct["gyro"], pct["wheels"]),
        f"fused {shown('fused')} %, gyro alone {shown('gyro')} %, "
        f"wheels alone {shown('wheels')} % (means over seeds, their 95 % t intervals)",
    )


def clustered_share_pvalue(shares: Sequence[float], counts: Sequence[int], p0: float) -> float:
    """Two-sided p-value of a coverage share against its nominal content, drives as clusters.

    An exact binomial test takes every window as independent. Windows of one drive share
    its tyres, load, road and weather, and miss together, so the share varies between
    drives more than a binomial says. Here the pooled share ``p̂ = Σ n_d s_d / N`` (drive
    ``d``'s share ``s_d`` of its ``n_d`` windows) gets the cluster-robust variance of a
    ratio estimator (Liang and Zeger 1986), ``D / (D − 1) Σ (n_d (s_d − p̂))² / N²`` over
    the ``D`` drives, and ``(p̂ − p0) / se`` is referred to Student's t with ``D − 1``
    degrees of freedom, the small-cluster reference of Cameron and Miller (2015, "A
    practitioner's guide to cluster-robust inference", section VI). With few drives that
    variance is itself noisy and can come out small by chance (drives that happen to
    agree), so ``se²`` is at least the binomial variance under the nominal share,
    ``p0 (1 − p0) / N``, and its reference, t with ``D − 1`` degrees of freedom, is wider
    than the normal: the test is never less cautious than the binomial's normal
    approximation.

    Args:
        shares: (D,) each drive's share of windows inside the region (a mean over seeds
            of the same windows is fine: the estimator is linear in them).
        counts: (D,) each drive's number of windows.
        p0: the nominal content (0.6827, 0.9545).

    Returns:
        The p-value; NaN with fewer than two drives that have windows (nothing to tell
        a drive's shift from chance by).
    """
    from scipy.stats import t as student_t

    pairs = [(float(s), float(n)) for s, n in zip(shares, counts, strict=True) if n > 0]
    if len(pairs) < 2:
        return float("nan")
    total = sum(n for _, n in pairs)
    pooled = sum(n * s for s, n in pairs) / total
    d = len(pairs)
    var = d / (d - 1) * sum((n * (s - pooled)) ** 2 for s, n in pairs) / total**2
    se = math.sqrt(max(var, p0 * (1.0 - p0) / total))
    return float(2.0 * student_t.sf(abs(pooled - p0) / se, df=d - 1))


def _unlikely(
    cells: list[tuple[str, dict]],
    one: str,
    two: str,
    drives: Mapping[str, Mapping[str, dict]] | None = None,
) -> str:
    """The cells whose share of windows a calibrated prediction would rarely give.

    A share of n windows scatters by chance around the nominal content: with 37
    windows a calibrated 2σ region holds all of them about one time in six. Each
    cell's share (the mean over seeds, of the same windows) is put to an exact
    two-sided binomial test against its nominal content at 5 %; the cells it
    rejects are the misses a sample this size does not explain if the windows were
    independent. They are not: the windows of one test drive share its tyres, load
    and weather and miss together, and a world has four test drives. Where the
    shares by test drive are given (``drives``: drive → outage → cell), a miss the
    binomial rejects is put to the drive-clustered test too
    (:func:`clustered_share_pvalue`), and the misses both
    reject are named apart: the ones four drives' spread does not explain either.
    """
    from scipy.stats import binomtest

    (p1, _), (p2, _) = COVER_BANDS
    out, clustered, n_drives = [], [], 0
    for L, c in cells:
        n = int(c.get("n_windows") or 0)
        by = [d[L] for d in (drives or {}).values() if (d.get(L) or {}).get("n_windows")]
        for key, p, label in ((one, p1, "1σ"), (two, p2, "2σ")):
            if not n or binomtest(round(c[key] * n), n, p).pvalue >= 0.05:
                continue
            out.append(f"{L} {label} ({100 * c[key]:.0f} % of {n})")
            if len(by) >= 2:
                n_drives = max(n_drives, len(by))
                shares = [b[key] for b in by]
                counts = [b["n_windows"] for b in by]
                if clustered_share_pvalue(shares, counts, p) < 0.05:
                    clustered.append(out[-1])
    if not out:
        return "every cell within what chance gives a calibrated prediction (binomial, 5 %)"
    said = "beyond chance (binomial, 5 %): " + ", ".join(out)
    if not n_drives:
        return said
    return (
        f"{said}; with each test drive's windows together ({n_drives} drives, "
        "cluster-robust t, 5 %): " + (", ".join(clustered) if clustered else "none")
    )


@dataclass(frozen=True)
class BandTally:
    """Coverage cells against the 68 ± 5 / 95 ± 3 % bands, with what chance would give.

    Attributes:
        cells: cells counted (two per outage length with windows: 1σ and 2σ).
        inside, above, below: cells inside the band, above it (the region too wide),
            below it (too narrow).
        chance_inside, chance_above, chance_below: the expected counts for a calibrated
            prediction on the same numbers of windows (:func:`band_chance`).
    """

    cells: int = 0
    inside: int = 0
    above: int = 0
    below: int = 0
    chance_inside: float = 0.0
    chance_above: float = 0.0
    chance_below: float = 0.0

    def __add__(self, other: BandTally) -> BandTally:
        return BandTally(*(a + b for a, b in zip(astuple(self), astuple(other), strict=True)))

    def said(self) -> str:
        return (
            f"{self.inside} of {self.cells} cells inside the band, {self.above} above "
            f"(regions too wide), {self.below} below; a calibrated prediction on these "
            f"numbers of windows: {self.chance_inside:.1f} / {self.chance_above:.1f} / "
            f"{self.chance_below:.1f} by chance (independent windows; fewer inside where a "
            "drive's windows miss together)"
        )


def _ordered(cells: dict[str, dict]) -> list[tuple[str, dict]]:
    return sorted(
        ((L, c) for L, c in cells.items() if L.endswith("s") and isinstance(c, dict)),
        key=lambda kv: int(kv[0].removesuffix("s")),
    )


def band_tally(cells: dict[str, dict], one: str, two: str) -> BandTally:
    """Count the cells (each outage length's ``one`` and ``two`` shares) against the bands."""
    tally = BandTally()
    for _, c in _ordered(cells):
        n = int(c.get("n_windows") or 0)
        for key, (p, tol) in zip((one, two), COVER_BANDS, strict=True):
            share = c.get(key)
            if not n or share is None or not math.isfinite(share):
                continue
            inside, above, below = band_chance(n, p, tol)
            tally += BandTally(
                1,
                int(abs(share - p) <= tol),
                int(share > p + tol),
                int(share < p - tol),
                inside,
                above,
                below,
            )
    return tally


def _coverage(
    cells: dict[str, dict],
    one: str,
    two: str,
    drives: Mapping[str, Mapping[str, dict]] | None = None,
) -> Verdict:
    """Every outage length's shares inside 68 ± 5 % (``one``) and 95 ± 3 % (``two``)."""
    (p1, tol1), (p2, tol2) = COVER_BANDS
    ordered = _ordered(cells)
    inside = [abs(c[one] - p1) <= tol1 and abs(c[two] - p2) <= tol2 for _, c in ordered]
    shares = ", ".join(f"{L} {100 * c[one]:.0f} / {100 * c[two]:.0f} %" for L, c in ordered)
    tally = band_tally(cells, one, two)
    return Verdict(
        all(inside),
        f"1σ / 2σ: {shares}; {tally.said()}; {_unlikely(ordered, one, two, drives)}",
    )


def fused_coverage(w: World) -> Verdict:
    """The fused prediction's 68.27 / 95.45 % regions (the filter's covariance calibrated on
    training windows) hold 68 ± 5 % / 95 ± 3 % at every outage length."""
    fused = _fused_cells(w)
    if not fused:
        return Verdict(None, "no navigation filter in eval.json")
    drives = w.ev.get("position_controls", {}).get("by_drive", {})
    verdict = _coverage(fused, "cover_1sigma", "cover_2sigma", drives)
    at = {d: c[w.longest] for d, c in drives.items() if c.get(w.longest, {}).get("n_windows")}
    if not at:
        return verdict
    each = ", ".join(
        f"{d} {100 * c['cover_1sigma']:.0f} / {100 * c['cover_2sigma']:.0f} % ({c['n_windows']})"
        for d, c in at.items()
    )
    return Verdict(verdict.holds, f"{verdict.evidence}; by test drive at {w.longest}: {each}")


def crse_coverage(w: World) -> Verdict:
    """R-WhONet's per-window CRSE within 1σ / 2σ of its prediction (calibrated on the training
    windows) in 68 ± 5 % / 95 ± 3 % of windows at every outage length."""
    cells = _crse_cells(w)
    if not cells:
        return Verdict(None, "no CRSE prediction in eval.json")
    by_drive = w.ev.get("uncertainty", {}).get("by_drive")
    return _coverage(cells, "crse_cover_1sigma", "crse_cover_2sigma", by_drive)


def _fused_cells(w: World) -> dict[str, dict] | None:
    rows = _fused(w)
    return rows.get("fused") if rows else None


def _crse_cells(w: World) -> dict[str, dict] | None:
    return w.ev.get("uncertainty", {}).get("models", {}).get("R")


def distance_model_same_position(w: World) -> Verdict:
    """Every model's fused error within 0.1 % of the distance of the GNSS distances' own."""
    rows, position = _fused(w), w.ev.get("position", {})
    gnss = rows.get("fused, GNSS distance", {}).get(w.longest) if rows else None
    cells = {m: c.get(w.longest) for m, c in position.items() if isinstance(c, dict)}
    pcts = {m: c["pos_pct"] for m, c in cells.items() if isinstance(c, dict) and "pos_pct" in c}
    if not gnss or not pcts:
        return Verdict(None, "no per-model position in eval.json")
    far = max(pcts, key=lambda m: abs(pcts[m] - gnss["pos_pct"]))
    return Verdict(
        all(abs(p - gnss["pos_pct"]) <= SAME_POSITION_PCT for p in pcts.values()),
        f"GNSS's own distances {gnss['pos_pct']:.2f} %; models {min(pcts.values()):.2f}-"
        f"{max(pcts.values()):.2f} % (farthest: {far})",
    )


CLAIMS: list[tuple[str, Callable[[World], Verdict]]] = [
    ("Recalibrating G on the new car's first seconds lowers its error", recalibration_helps),
    ("R as the pipeline chooses it is within 5 % of min(G, S) or better", r_near_best),
    ("The recipe `auto` falls back to is no worse than G at any m", default_no_harm),
    ("Continuous recalibration is within 5 % of S or better", continuous_near_s),
    ("The network adds nothing measurable beyond one tyre radius", network_beyond_radius),
    ("G barely changes the WPM on the new car (within ±5 %)", g_like_wpm),
    ("At the smallest m, some recipe does harm (worse than G on average)", ten_seconds_harm),
    (
        "2D: the fused filter ends the longest outages within 2 % of the distance driven",
        fused_within_2pct,
    ),
    ("2D: fused beats the gyro alone and the wheels alone", fused_beats_each_sensor),
    ("2D: the fused 1σ / 2σ regions hold 68 ± 5 % / 95 ± 3 % of windows", fused_coverage),
    (
        "R-WhONet's window CRSE is inside its 1σ / 2σ in 68 ± 5 % / 95 ± 3 % of windows",
        crse_coverage,
    ),
    (
        "2D: the distance model does not change the position (within 0.1 % of the distance)",
        distance_model_same_position,
    ),
]


def coverage_summary(worlds: Sequence[World]) -> str:
    """The coverage cells of every world together, against what chance gives (one line)."""
    parts = []
    for what, get, one, two in (
        ("2D, fused", _fused_cells, "cover_1sigma", "cover_2sigma"),
        ("R-WhONet's CRSE", _crse_cells, "crse_cover_1sigma", "crse_cover_2sigma"),
    ):
        tally = BandTally()
        for w in worlds:
            tally += band_tally(get(w) or {}, one, two)
        if tally.cells:
            parts.append(f"{what}: {tally.said()}")
    if not parts:
        return "Coverage: no calibrated prediction in these evaluations."
    return f"Coverage over the {len(worlds)} worlds' cells. " + ". ".join(parts) + "."


def verdicts(worlds: Sequence[World]) -> list[tuple[str, list[Verdict]]]:
    """Every claim in every world."""
    return [(text, [check(w) for w in worlds]) for text, check in CLAIMS]


def _mark(v: Verdict) -> str:
    return {True: "holds", False: "**does not hold**", None: "n/a"}[v.holds]


def render(worlds: Sequence[World]) -> str:
    """The markdown section: one table of claims by world, then the evidence per world."""
    head = "| claim | " + " | ".join(f"`{w.name}`" for w in worlds) + " |"
    lines = [
        BEGIN,
        "<!-- Written by `python -m rwhonet.report.worlds` (make worlds); edit the code, "
        "not this section. -->",
        "",
        head,
        "|---|" + "---|" * len(worlds),
    ]
    table = verdicts(worlds)
    for text, row in table:
        lines.append(f"| {text} | " + " | ".join(_mark(v) for v in row) + " |")
    lines.append("")
    lines += [coverage_summary(worlds), ""]
    for i, w in enumerate(worlds):
        recipe, m = _chosen(w)
        lines += [
            f"**`{w.name}`** ({w.ev.get('n_seeds')} seeds; R-WhONet = `{recipe}`"
            + (f" at m = {m} s" if m is not None else "")
            + f"; mean CRSE at {w.longest.removesuffix('s')} s over all target test windows; "
            f"tables: `{w.folder}/reports/tables.md`, MLflow: `{w.folder}/mlruns`):",
            "",
        ]
        lines += [f"- {text}: {_mark(row[i])}. {row[i].evidence}." for text, row in table]
        lines.append("")
    lines.append(END)
    return "\n".join(lines) + "\n"


def load_world(folder: Path) -> World:
    """One world from the folder it ran in (``params.yaml``, ``metrics/eval.json``).

    Raises:
        FileNotFoundError: the folder holds no evaluation.
    """
    ev = json.loads((folder / "metrics" / "eval.json").read_text(encoding="utf-8"))
    params = yaml.safe_load((folder / "params.yaml").read_text(encoding="utf-8")) or {}
    name = params.get("sim", {}).get("profile", folder.name)
    if params.get("data", {}).get("source") == "files":
        name = folder.name
    return World(name, ev, params, str(folder))


def replace_section(text: str, section: str) -> str:
    """``text`` with its worlds section replaced by ``section`` (appended when absent)."""
    if BEGIN in text and END in text:
        before, rest = text.split(BEGIN, 1)
        after = rest.split(END, 1)[1]
        return before + section.rstrip("\n") + after
    return text.rstrip("\n") + "\n\n" + section


def main(argv: Sequence[str] | None = None) -> int:
    """Print the worlds section, or write it into a results file."""
    parser = argparse.ArgumentParser(
        prog="python -m rwhonet.report.worlds",
        description="Mark every headline claim as holding or not in each world's evaluation.",
    )
    parser.add_argument("folders", nargs="+", type=Path, help="world folders (build/worlds/*)")
    parser.add_argument("--results", type=Path, help="rewrite this file's worlds section")
    args = parser.parse_args(argv)
    worlds = []
    for folder in args.folders:
        try:
            worlds.append(load_world(folder))
        except FileNotFoundError as err:
            parser.error(f"{folder}: no evaluation ({err.filename}); run `make worlds` first")
    section = render(worlds)
    if args.results is None:
        print(section, end="")
        return 0
    text = args.results.read_text(encoding="utf-8") if args.results.is_file() else ""
    args.results.write_text(replace_section(text, section), encoding="utf-8")
    print(f"{args.results}: worlds section rewritten ({', '.join(w.name for w in worlds)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

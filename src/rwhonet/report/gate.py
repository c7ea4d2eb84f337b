"""CI regression gate on mean CRSE and CTE, and on the 2D position after the longest outage.

Compares the ``overall`` means of a fresh ``ci``-profile run (``metrics/eval.json``,
means over the ci profile's training seeds) with a committed baseline
(``metrics/baseline-ci.json``), and every model's mean horizontal error of the
navigation filter at the end of the longest outage (``position.<model>.<L>s.pos_mean``,
the fused filter: ``rwhonet.evaluation.position``). A baseline written before the
filter (no ``position_controls`` key: its ``position`` block holds the earlier
dead reckoning, another quantity) gates CRSE and CTE only and says so; refreshing
the baseline adds the position rows. A value is a regression when it exceeds its
baseline by more than ``gate.rel_tol`` of the baseline plus ``gate.abs_tol_m``
(CTE can be near zero, where a relative change alone means nothing); so is a
model or outage missing from the new run. Lower is better, so improvements
pass; the table says which way every value moved (refresh the baseline on
purpose to lock an improvement in: see README).

Usage::

    rwhonet-gate [--eval metrics/eval.json] [--baseline metrics/baseline-ci.json]
                 [--rel-tol 0.1] [--abs-tol 0.5]
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

from rwhonet import paths
from rwhonet.io import read_json

METRICS = ("crse", "cte", "pos")
FILTER_KEY = "position_controls"  # present in an eval.json whose "position" is the filter's
SAME = 1e-9  # relative change below which a value counts as unchanged


@dataclass(frozen=True)
class GateRow:
    model: str
    outage: str
    metric: str
    baseline: float
    now: float | None

    @property
    def change(self) -> float | None:
        if self.now is None or self.baseline == 0:
            return None
        return (self.now - self.baseline) / self.baseline

    def direction(self) -> str:
        """``better``, ``worse`` or ``same`` (lower is better), ``missing`` without a value."""
        if self.now is None or not math.isfinite(self.now):
            return "missing"
        if abs(self.now - self.baseline) <= SAME * max(abs(self.baseline), 1.0):
            return "same"
        return "better" if self.now < self.baseline else "worse"

    def failed(self, rel_tol: float, abs_tol: float) -> bool:
        if self.now is None or not math.isfinite(self.now):
            return True
        return self.now > self.baseline * (1.0 + rel_tol) + abs_tol


def means(eval_json: dict) -> dict[tuple[str, str, str], float]:
    """``{(model, outage, metric): mean over seeds}`` over all windows of all test drives.

    CRSE and CTE of every model and outage; ``pos``: the filter's mean horizontal
    error at the end of the longest outage, per model (none from an eval.json
    written before the filter).
    """
    out = {}
    for model, by_outage in eval_json["overall"].items():
        for outage, stats in by_outage.items():
            for metric in ("crse", "cte"):
                value = stats.get(f"{metric}_mean")
                if value is not None:
                    out[(model, outage, metric)] = float(value)
    if FILTER_KEY in eval_json:
        for model, by_outage in eval_json.get("position", {}).items():
            if not by_outage:
                continue
            longest = max(by_outage, key=lambda o: int(o[:-1]))
            value = by_outage[longest].get("pos_mean")
            if value is not None:
                out[(model, longest, "pos")] = float(value)
    return out


def compare(now: dict, baseline: dict) -> list[GateRow]:
    """Pair every baseline value with the new one (None when missing)."""
    new = means(now)

    def order(key: tuple[str, str, str]) -> tuple:
        model, outage, metric = key
        return (model, int(outage[:-1]), METRICS.index(metric))

    base = sorted(means(baseline).items(), key=lambda kv: order(kv[0]))
    return [GateRow(m, o, q, b, new.get((m, o, q))) for (m, o, q), b in base]


def render(rows: list[GateRow], rel_tol: float, abs_tol: float) -> str:
    """A readable table: baseline, now, change, direction, status."""
    lines = [
        f"{'model':<14} {'outage':>6} {'metric':>6} {'baseline':>10} {'now':>10} {'change':>8}"
        "  direction  status",
        "-" * 78,
    ]
    for r in rows:
        now = "missing" if r.now is None else f"{r.now:.3f}"
        change = "" if r.change is None else f"{100 * r.change:+.1f}%"
        status = "REGRESSION" if r.failed(rel_tol, abs_tol) else "ok"
        lines.append(
            f"{r.model:<14} {r.outage:>6} {r.metric.upper():>6} {r.baseline:>10.3f} {now:>10} "
            f"{change:>8}  {r.direction():<9}  {status}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the gate; return 0 when nothing regressed, 1 otherwise, 2 on missing files."""
    from rwhonet.config import load_params

    params = load_params()
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--eval", type=Path, default=paths.EVAL_JSON)
    ap.add_argument("--baseline", type=Path, default=paths.ROOT / params.gate.baseline)
    ap.add_argument("--rel-tol", type=float, default=params.gate.rel_tol)
    ap.add_argument("--abs-tol", type=float, default=params.gate.abs_tol_m)
    args = ap.parse_args(argv)
    for f in (args.eval, args.baseline):
        if not f.is_file():
            print(f"gate: {f} not found", file=sys.stderr)
            return 2
    now, baseline = read_json(args.eval), read_json(args.baseline)
    rows = compare(now, baseline)
    if not rows:
        print(f"gate: {args.baseline} holds no mean CRSE/CTE values", file=sys.stderr)
        return 2
    seeds = f"{now.get('n_seeds', 1)} seed(s) {now.get('seeds', '')}".strip()
    print(
        f"CRSE/CTE/position gate: {args.eval} ({seeds}) vs {args.baseline}; a value fails "
        f"above baseline x (1 + {args.rel_tol:g}) + {args.abs_tol:g} m"
    )
    if FILTER_KEY not in baseline:
        print(
            f"Note: {args.baseline} predates the navigation filter: the 2D position is not "
            "gated until the baseline is refreshed (make baseline-ci)."
        )
    print(render(rows, args.rel_tol, args.abs_tol))
    counts = {d: sum(r.direction() == d for r in rows) for d in ("better", "same", "worse")}
    print(f"\n{counts['better']} better, {counts['same']} unchanged, {counts['worse']} worse.")
    bad = [r for r in rows if r.failed(args.rel_tol, args.abs_tol)]
    if bad:
        print(f"FAIL: {len(bad)} regression(s).", file=sys.stderr)
        return 1
    print("PASS: no regression.")
    return 0


if __name__ == "__main__":
    sys.exit(main())

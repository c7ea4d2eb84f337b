"""CI regression gate on mean CRSE per model and outage length.

Compares the ``overall`` mean CRSE of a fresh ``ci``-profile run
(``metrics/eval.json``) with a committed baseline (``metrics/baseline-ci.json``).
A value more than ``gate.rel_tol`` above its baseline is a regression; so is a
model or outage missing from the new run. Lower is better, so improvements
pass (refresh the baseline on purpose to lock them in: see README).

Usage::

    rwhonet-gate [--eval metrics/eval.json] [--baseline metrics/baseline-ci.json] [--rel-tol 0.1]
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

from rwhonet import paths
from rwhonet.io import read_json

GATED_MODELS = ("WPM", "G", "S", "R")


@dataclass(frozen=True)
class GateRow:
    model: str
    outage: str
    baseline: float
    now: float | None

    @property
    def change(self) -> float | None:
        if self.now is None or self.baseline == 0:
            return None
        return (self.now - self.baseline) / self.baseline

    def failed(self, rel_tol: float) -> bool:
        if self.now is None or not math.isfinite(self.now):
            return True
        return self.now > self.baseline * (1.0 + rel_tol)


def mean_crse(eval_json: dict) -> dict[tuple[str, str], float]:
    """``{(model, outage): mean CRSE}`` over all evaluation windows of all drives."""
    out = {}
    for model, by_outage in eval_json["overall"].items():
        if model not in GATED_MODELS:
            continue
        for outage, stats in by_outage.items():
            out[(model, outage)] = float(stats["crse_mean"])
    return out


def compare(now: dict, baseline: dict) -> list[GateRow]:
    """Pair every baseline (model, outage) with the new value (None when missing)."""
    new = mean_crse(now)
    base = sorted(mean_crse(baseline).items(), key=lambda kv: (kv[0][0], int(kv[0][1][:-1])))
    return [GateRow(m, o, b, new.get((m, o))) for (m, o), b in base]


def render(rows: list[GateRow], rel_tol: float) -> str:
    """A readable table: baseline, now, change, status."""
    lines = [
        f"{'model':<6} {'outage':>6} {'baseline CRSE':>14} {'now CRSE':>10} {'change':>8}  status",
        "-" * 60,
    ]
    for r in rows:
        now = "missing" if r.now is None else f"{r.now:.3f}"
        change = "" if r.change is None else f"{100 * r.change:+.1f}%"
        status = "REGRESSION" if r.failed(rel_tol) else "ok"
        lines.append(
            f"{r.model:<6} {r.outage:>6} {r.baseline:>14.3f} {now:>10} {change:>8}  {status}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the gate; return 0 when nothing regressed, 1 otherwise."""
    from rwhonet.config import load_params

    params = load_params()
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--eval", type=Path, default=paths.EVAL_JSON)
    ap.add_argument("--baseline", type=Path, default=paths.ROOT / params.gate.baseline)
    ap.add_argument("--rel-tol", type=float, default=params.gate.rel_tol)
    args = ap.parse_args(argv)
    for f in (args.eval, args.baseline):
        if not f.is_file():
            print(f"gate: {f} not found", file=sys.stderr)
            return 2
    rows = compare(read_json(args.eval), read_json(args.baseline))
    if not rows:
        print(f"gate: {args.baseline} holds no mean CRSE values", file=sys.stderr)
        return 2
    print(f"Mean CRSE gate: {args.eval} vs {args.baseline} (tolerance +{100 * args.rel_tol:.0f}%)")
    print(render(rows, args.rel_tol))
    bad = [r for r in rows if r.failed(args.rel_tol)]
    if bad:
        print(f"\nFAIL: {len(bad)} regression(s) in mean CRSE.", file=sys.stderr)
        return 1
    print("\nPASS: no mean CRSE regression.")
    return 0


if __name__ == "__main__":
    sys.exit(main())

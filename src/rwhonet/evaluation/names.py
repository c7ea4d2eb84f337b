"""The models and controls an evaluation reports, and their names.

- ``WPM``: the wheel-odometry physics model of ``label.wpm_mode`` (e = label);
  ``WPM-ref`` / ``WPM-int``: the same radii in the other WPM mode;
- ``G``, ``S``: the networks trained on the source and on the target car;
- ``R[<recipe>]@m``: G recalibrated on each drive's first m seconds by every
  recipe of ``adapt.recipes``; ``R[continuous]``: recalibrated before every window;
- ``R@m`` and ``R``: aliases of the chosen recipe (a
  :class:`~rwhonet.evaluation.selection.Choice`) at every m and at the chosen m
  (what the tables call R-WhONet);
- ``WPM-m@m``: the WPM with its rear radii refitted on the drive's first m
  seconds, the network-free control.
"""

from __future__ import annotations

from rwhonet.config import Params
from rwhonet.contracts import CONTINUOUS_RECIPES, alt_wpm, recipe_model
from rwhonet.evaluation.selection import Choice


def recipe_models(params: Params) -> list[str]:
    """Every recipe's R-WhONet at every m."""
    return [
        recipe_model(r, m)
        for r in params.adapt.recipes
        for m in ([None] if r in CONTINUOUS_RECIPES else params.adapt.m_grid)
    ]


def aliases(params: Params, choice: Choice) -> dict[str, str]:
    """``R@m`` and ``R``: the chosen recipe at every m and at the chosen m."""
    out = {f"R@{m}": recipe_model(choice.recipe, m) for m in params.adapt.m_grid}
    out["R"] = choice.model
    return out


def model_names(params: Params, choice: Choice) -> list[str]:
    """Every model and control the evaluation reports, in table order."""
    alt, _ = alt_wpm(params.label.wpm_mode)
    return [
        "WPM",
        alt,
        "G",
        "S",
        *aliases(params, choice),
        *recipe_models(params),
        *(f"WPM-m@{m}" for m in params.adapt.m_grid),
    ]


def pairs(params: Params, choice: Choice) -> list[tuple[str, str]]:
    """The paired differences reported (first minus second, per seed)."""
    m = choice.m
    out = [("R", "G"), ("R", "S"), ("R", f"WPM-m@{m}")]
    out += [
        ("R", recipe_model(r, m))
        for r in params.adapt.recipes
        if recipe_model(r, m) != choice.model
    ]
    return out


def at_chosen_m(params: Params, choice: Choice) -> list[str]:
    """Every recipe at the chosen m (``R[continuous]`` as it is), in ``adapt.recipes`` order."""
    return [recipe_model(r, choice.m) for r in params.adapt.recipes]


def position_models(params: Params, choice: Choice) -> list[str]:
    """The models dead-reckoned in 2D: the WPM, G, S, every recipe at the chosen m, WPM-m."""
    return ["WPM", "G", "S", f"WPM-m@{choice.m}", *at_chosen_m(params, choice)]


def scenario_models(params: Params, choice: Choice) -> list[str]:
    """The models of the scenario outages: WPM, G, S, R, WPM-m and the other recipes at m."""
    others = [m for m in at_chosen_m(params, choice) if m != choice.model]
    return ["WPM", "G", "S", "R", f"WPM-m@{choice.m}", *others]

"""R-WhONet: G-WhONet recalibrated on a few seconds of a new car (paper §2.6, §3.3.3).

The paper fine-tunes G with G's own recipe (Table 1) on the first m seconds of
each target test drive. The recipes here (``adapt.recipes``) are that and the
alternatives a reviewer asks for; each takes G and the m seconds and returns
an :class:`AdaptResult`:

- ``paper`` / ``head``: :func:`fine_tune`, every weight or the linear head only,
  ``adapt.epochs`` passes of the training loop of :mod:`rwhonet.models.loop`;
- ``steps``: :func:`fine_tune_steps`, the paper recipe with a step budget and
  early stopping on a held-back tail of the m seconds;
- ``ridge_head``: :func:`ridge_head`, the head refitted in closed form on G's
  frozen hidden features, shrunk towards G's head;
- ``radius+G``: :func:`radius_g`, the WPM's rear radii refitted on the m seconds
  (the calibration's estimator) to what G on top leaves unexplained, G unchanged;
- ``shrink``: :func:`shrink`, that refit shrunk towards G by what the m seconds
  can tell (:class:`ShrinkEvidence`, measured on drives where the answer is known);
- ``continuous`` / ``continuous_shrink``: :func:`continuous_predictions`, an inner
  recipe refitted before every outage window on the drive's seconds before it.

:func:`label_prediction` turns any result into predictions of the label
(GNSS − WPM with the source calibration), so every recipe is scored alike.
Plain torch, no Trainer: one stage process recalibrates every drive at every
m, and Lightning's import and per-fit set-up would cost more than the
fine-tuning itself (``benchmarks/bench_train.py`` measures both).
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from rwhonet import contracts
from rwhonet.config import AdaptParams
from rwhonet.errors import InputError, Problem
from rwhonet.features.calibration import refit, refit_radii
from rwhonet.features.sequences import LabelledWindows
from rwhonet.features.wpm import radius_corrected
from rwhonet.models.freeze import apply_trainable, count_parameters
from rwhonet.models.loop import (
    ArrayDataset,
    EpochLoss,
    as_model_inputs,
    make_optimizer,
    predict,
    seed_all,
    train_block,
    train_epoch,
    train_loader,
)
from rwhonet.models.whonet import WhONet

if TYPE_CHECKING:  # for the annotation only: not imported at run time
    from rwhonet.features.samples import SampleSet

GRADIENT_RECIPES = ("paper", "head", "steps")
SHRINK_RIDGE = "shrink+ridge_head"  # the continuous_shrink recipe's inner recipe


@dataclass
class AdaptData(LabelledWindows):
    """A stretch of one drive to recalibrate on (or predict for): its samples and WPM inputs.

    Attributes:
        x: (n, seq_len, n_features) float32 windows.
        y: (n,) labels in metres (GNSS − WPM with the source calibration).
        disp_gnss_m: (n,) GNSS displacement per second, metres.
        angle_rl_rad: (n,) rear-left wheel angle per second (the WPM's mode), rad.
        angle_rr_rad: (n,) rear-right wheel angle per second, rad.
    """

    disp_gnss_m: np.ndarray
    angle_rl_rad: np.ndarray
    angle_rr_rad: np.ndarray

    def take(self, idx: np.ndarray) -> AdaptData:
        """The samples at ``idx`` (an index array or a boolean mask)."""
        return AdaptData(
            *(
                a[idx]
                for a in (self.x, self.y, self.disp_gnss_m, self.angle_rl_rad, self.angle_rr_rad)
            )
        )


def adapt_data(samples: SampleSet, mask: np.ndarray) -> AdaptData:
    """The :class:`AdaptData` of the samples where ``mask`` holds (order kept).

    Args:
        samples: stacked samples (:func:`rwhonet.features.samples.stack_segments`).
        mask: (N,) which samples.
    """
    f = samples.frame[mask]
    return AdaptData(
        samples.x[mask],
        samples.y[mask],
        *(
            f[c].to_numpy(np.float64)
            for c in (contracts.DISP_GNSS_M, contracts.ANGLE_RL_RAD, contracts.ANGLE_RR_RAD)
        ),
    )


@dataclass
class AdaptResult:
    """A recalibrated model and how it was obtained.

    Attributes:
        net: the network (a copy of G's, changed by the recipe; in eval mode).
        hparams: its hyperparameters; ``lr`` and ``batch_size`` are the recipe's.
        radii: the WPM rear radii ``(r_rl, r_rr)`` the model corrects, when the
            recipe refitted them (``radius+G``); None: the source calibration.
        history: per epoch or step ``{"epoch", "train_loss", "val_loss"}`` (MAE, m;
            ``val_loss`` on the held-back tail for ``steps``, else None).
        seconds: wall time of the recalibration.
        n_trainable: weights the recipe changes.
        n_total: all weights of the network.
        info: recipe-specific facts (steps taken, penalty, fallbacks).
    """

    net: WhONet
    hparams: dict[str, Any]
    radii: tuple[float, float] | None
    history: list[dict[str, Any]]
    seconds: float
    n_trainable: int
    n_total: int
    info: dict[str, Any] = field(default_factory=dict)


def _inputs(base: WhONet, hparams: dict[str, Any], data: AdaptData) -> tuple:
    return as_model_inputs(
        data.x,
        data.y,
        "adaptation samples",
        seq_len=hparams["seq_len"],
        n_features=hparams["n_features"],
    )


def _trainable_copy(base: WhONet, seed: int, trainable: str) -> tuple[WhONet, tuple[int, int]]:
    """A gradient recipe's start: torch seeded, then a copy of G with the freeze policy applied.

    Returns:
        The copy, and its trainable weights and all its weights.
    """
    seed_all(seed)
    net = copy.deepcopy(base)
    return net, apply_trainable(net, trainable)


def _trained_result(
    net: WhONet,
    hparams: dict[str, Any],
    adapt: AdaptParams,
    history: list[dict[str, Any]],
    start: float,
    counts: tuple[int, int],
    **info: Any,
) -> AdaptResult:
    """A gradient recipe's result: ``net`` in eval mode, trained with ``adapt``'s lr and batch size.

    Args:
        start: ``time.perf_counter()`` when the recipe began.
        counts: trainable and all weights (:func:`_trainable_copy`).
        **info: the recipe's facts (:attr:`AdaptResult.info`).
    """
    net.eval()
    return AdaptResult(
        net,
        {**hparams, "lr": adapt.lr, "batch_size": adapt.batch_size},
        None,
        history,
        time.perf_counter() - start,
        *counts,
        info=info,
    )


def fine_tune(
    base: WhONet,
    hparams: dict[str, Any],
    data: AdaptData,
    *,
    adapt: AdaptParams,
    seed: int,
    trainable: str = "all",
) -> AdaptResult:
    """The paper's recipe: ``adapt.epochs`` passes of Adamax over the m seconds.

    A fresh Adamax (lr ``adapt.lr``) trains the weights the freeze policy
    ``trainable`` leaves trainable (``all``: paper; ``head``: the head recipe),
    in shuffled mini-batches of ``adapt.batch_size``, without validation.
    ``base`` is not modified.

    Args:
        base: G-WhONet's network.
        hparams: its hyperparameters (:data:`~rwhonet.models.loop.HPARAMS`).
        data: the m seconds.
        adapt: the recipes' settings (``adapt:`` in params.yaml).
        seed: seeds shuffling and dropout; the same seed and inputs give the same weights.
        trainable: the freeze policy (:mod:`rwhonet.models.freeze`).

    Returns:
        The fine-tuned network and its history.

    Raises:
        InputError: when the arrays do not fit the network or hold non-finite values.
    """
    x_t, y_t = _inputs(base, hparams, data)
    start = time.perf_counter()
    net, counts = _trainable_copy(base, seed, trainable)
    loader = train_loader(ArrayDataset(x_t, y_t), batch_size=adapt.batch_size, seed=seed)
    optimizer = make_optimizer(net, adapt.lr)
    net.train()
    history = []
    for epoch in range(adapt.epochs):
        loss_m = train_epoch(net, optimizer, loader, adapt.batch_size)
        history.append({"epoch": epoch, "train_loss": loss_m, "val_loss": None})
    return _trained_result(net, hparams, adapt, history, start, counts)


def fine_tune_steps(
    base: WhONet, hparams: dict[str, Any], data: AdaptData, *, adapt: AdaptParams, seed: int
) -> AdaptResult:
    """The paper's update with a step budget and early stopping (the ``steps`` recipe).

    The last ``adapt.steps.holdout_fraction`` of the m seconds (at least one
    second) is held back: a contiguous tail, since neighbouring seconds are
    strongly correlated. Adamax steps over shuffled mini-batches of the rest,
    for at most ``max_steps``; after every step the held-back MAE is measured,
    and the weights with the best one so far are kept. Training stops after
    ``patience`` steps without a better one. Whatever m is, the number of
    updates is bounded, where the paper's 80 epochs give 80 steps for m ≤ 128.

    Args:
        base: G-WhONet's network.
        hparams: its hyperparameters.
        data: the m seconds (at least two).
        adapt: the recipes' settings.
        seed: seeds shuffling and dropout.

    Returns:
        The network with the best held-back MAE (G's own if no step improved it).
    """
    cfg = adapt.steps
    x_t, y_t = _inputs(base, hparams, data)
    n_hold = min(max(1, round(len(y_t) * cfg.holdout_fraction)), len(y_t) - 1)
    if n_hold < 1:
        raise ValueError("the steps recipe needs at least two seconds")
    x_fit, y_fit, x_hold, y_hold = x_t[:-n_hold], y_t[:-n_hold], x_t[-n_hold:], y_t[-n_hold:]
    start = time.perf_counter()
    net, counts = _trainable_copy(base, seed, "all")
    optimizer = make_optimizer(net, adapt.lr)
    loader = train_loader(
        ArrayDataset(x_fit, y_fit), batch_size=adapt.batch_size, seed=seed, steps_per_block=1
    )

    def held_back_mae() -> float:
        net.eval()
        with torch.no_grad():
            loss = float(torch.nn.functional.l1_loss(net(x_hold), y_hold))
        net.train()
        return loss

    best, best_state, best_step = held_back_mae(), copy.deepcopy(net.state_dict()), 0
    history, step = [{"epoch": 0, "train_loss": None, "val_loss": best}], 0
    net.train()
    while step < cfg.max_steps and step - best_step < cfg.patience:
        for xb, yb in loader:  # one pass over the fitting seconds, one step per mini-batch
            losses = EpochLoss()
            train_block(net, optimizer, xb, yb, adapt.batch_size, losses)
            step += 1
            hold = held_back_mae()
            history.append({"epoch": step, "train_loss": losses.pop_mean(), "val_loss": hold})
            if hold < best:
                best, best_state, best_step = hold, copy.deepcopy(net.state_dict()), step
            if step >= cfg.max_steps or step - best_step >= cfg.patience:
                break
    net.load_state_dict(best_state)
    return _trained_result(
        net,
        hparams,
        adapt,
        history,
        start,
        counts,
        steps=step,
        best_step=best_step,
        held_back_s=n_hold,
    )


def hidden_features(net: WhONet, x: np.ndarray | torch.Tensor) -> np.ndarray:
    """G's head inputs for every window (eval mode, no dropout): ``net.features``.

    Any network of :mod:`rwhonet.models.network` (WhONet: its last hidden state).

    Returns:
        (N, k) float64.
    """
    xt = torch.as_tensor(np.asarray(x, dtype=np.float32))
    was = net.training
    net.eval()
    try:
        with torch.no_grad():
            h = net.features(xt)
    finally:
        net.train(was)
    return h.numpy().astype(np.float64)


def ridge_solve(
    a: np.ndarray,
    y: np.ndarray,
    theta0: np.ndarray,
    penalty: float,
    *,
    gram: np.ndarray | None = None,
    moment: np.ndarray | None = None,
) -> np.ndarray:
    """Least squares ``y ≈ a θ`` shrunk towards ``θ0``, with a penalty per row of data.

    Minimises ``(1/n) |y − a θ|² + penalty · |θ − θ0|²``:
    ``(aᵀa + n·penalty·I) θ = aᵀy + n·penalty·θ0``. The penalty is per row (one
    second of data), so its meaning does not change with the number of rows.
    ``penalty = 0`` is ordinary least squares (the minimum-norm solution when there
    are fewer rows than unknowns); ``penalty = inf`` returns ``θ0``.

    Args:
        a: (n, k) design matrix.
        y: (n,) targets.
        theta0: (k,) what ``θ`` is shrunk towards.
        penalty: ridge strength per row, >= 0.
        gram: ``aᵀa`` when the caller has it already (accumulated row by row).
        moment: ``aᵀy`` likewise.

    Returns:
        (k,) float64 ``θ``.
    """
    if math.isinf(penalty):
        return np.array(theta0, dtype=np.float64)
    if penalty == 0:
        return np.linalg.lstsq(a, y, rcond=None)[0]
    lam = len(y) * penalty
    gram = a.T @ a if gram is None else gram
    moment = a.T @ y if moment is None else moment
    return np.linalg.solve(gram + lam * np.eye(len(theta0)), moment + lam * theta0)


def head_design(h: np.ndarray) -> np.ndarray:
    """The head's design matrix ``[h, 1]`` (weights, then the bias), float64."""
    return np.hstack([np.asarray(h, np.float64), np.ones((len(h), 1))])


def ridge_head_weights(
    h: np.ndarray, y: np.ndarray, w0: np.ndarray, b0: float, penalty: float
) -> tuple[np.ndarray, float]:
    """The head ``y ≈ h w + b`` in closed form, shrunk towards ``(w0, b0)`` (:func:`ridge_solve`).

    Minimises ``(1/n) Σ (y − h w − b)² + penalty · (|w − w0|² + (b − b0)²)``.

    Args:
        h: (n, k) hidden features.
        y: (n,) labels, metres.
        w0: (k,) the head's weights to shrink towards (G's).
        b0: its bias.
        penalty: ridge strength per second of data, >= 0.

    Returns:
        ``(w, b)``.
    """
    theta0 = np.append(np.asarray(w0, np.float64), b0)
    theta = ridge_solve(head_design(h), np.asarray(y, np.float64), theta0, penalty)
    return theta[:-1], float(theta[-1])


def ridge_head(
    base: WhONet, hparams: dict[str, Any], data: AdaptData, *, penalty: float
) -> AdaptResult:
    """The ``ridge_head`` recipe: G's head refitted on the m seconds in closed form.

    Args:
        base: G-WhONet's network (its hidden layer stays frozen).
        hparams: its hyperparameters.
        data: the m seconds.
        penalty: ``adapt.ridge_penalty`` (see :func:`ridge_head_weights`).

    Returns:
        G with the refitted head.
    """
    _inputs(base, hparams, data)
    start = time.perf_counter()
    net = copy.deepcopy(base)
    w, b = ridge_head_weights(
        hidden_features(net, data.x),
        data.y,
        net.head.weight.detach().numpy()[0],
        float(net.head.bias.detach()[0]),
        penalty,
    )
    with torch.no_grad():
        net.head.weight.copy_(torch.as_tensor(w, dtype=torch.float32)[None, :])
        net.head.bias.fill_(b)
    net.eval()
    n_head = count_parameters(net.head)[1]
    return AdaptResult(
        net,
        dict(hparams),
        None,
        [],
        time.perf_counter() - start,
        n_head,
        count_parameters(net)[1],
        info={"ridge_penalty": penalty},
    )


def _radii_result(
    base: WhONet,
    hparams: dict[str, Any],
    radii: tuple[float, float] | None,
    start: float,
    info: dict[str, Any],
) -> AdaptResult:
    """A radius recipe's result: G unchanged under the rear radii ``radii``.

    The two radii are the weights the recipe changes (``n_trainable``).

    Args:
        radii: the refitted rear radii; None: the source calibration.
        start: ``time.perf_counter()`` when the recipe began.
        info: the recipe's facts (:attr:`AdaptResult.info`).
    """
    return AdaptResult(
        copy.deepcopy(base).eval(),
        dict(hparams),
        radii,
        [],
        time.perf_counter() - start,
        2,
        count_parameters(base)[1] + 2,
        info=info,
    )


def radius_g(
    base: WhONet, hparams: dict[str, Any], data: AdaptData, *, min_speed_m_s: float
) -> AdaptResult:
    """The ``radius+G`` recipe: the WPM's rear radii refitted on the m seconds, G unchanged.

    The radii are fitted with G on top (``Σ (GNSS − G) / Σ wheel angle``), so that
    WPM + G, the model this recipe predicts with, adds up to the GNSS distance over
    the m seconds. Refitting the radii to GNSS alone and then adding G counts G's
    mean correction twice: G learned it against the source calibration, and the
    refit already removes the scale error it stood for.

    Args:
        base: G-WhONet's network (kept as is).
        hparams: its hyperparameters.
        data: the m seconds.
        min_speed_m_s: seconds slower than this are left out of the refit.

    Returns:
        G with the refitted radii; ``radii`` None (the source calibration kept)
        when no second moved fast enough, recorded in ``info``.
    """
    start = time.perf_counter()
    g_pred = predict(base, data.x, seq_len=hparams["seq_len"]).astype(np.float64)
    radii = refit_radii(
        data.disp_gnss_m, data.angle_rl_rad, data.angle_rr_rad, min_speed_m_s, explained_m=g_pred
    )
    return _radii_result(base, hparams, radii, start, {"radius_refit": radii is not None})


# --------------------------------------------------------------------------- shrink
#
# The ``shrink`` recipe. After G and the source calibration, a drive's per-second
# residual is modelled as r_t = GNSS_t − WPM_t − G_t = δ·d_t + ε_t: d_t the WPM's
# distance with the source radii, δ the drive's relative change of rear radius
# (one scale for both rear wheels), ε_t what a constant scale cannot explain (the
# GNSS error, correlated over tens of seconds; slip; the drive changing as it goes).
# The refit on the first k seconds (radius+G's estimator) gives δ̂ = δ + E/D, D the
# GNSS distance it rests on and E what it gets wrong over that distance. With a prior
# δ ~ N(0, τ²) centred on G and E ~ N(0, V(k)), the posterior mean of δ is w·δ̂, with
#     w = τ² / (τ² + V(k) / D²),                      posterior sd  √(w · V(k) / D²)
# (the normal-normal model with known variances: Gelman et al., Bayesian Data Analysis,
# 3rd ed., §2.5; τ and V estimated from other drives, an empirical Bayes estimate).
# V(k) and τ are measured where the answer is known (:func:`evidence_terms`): on
# whole drives of a car, the first k seconds' refit against the refit on the rest
# of the same drive. So V(k) holds the receiver's correlated error, what a drive's
# first seconds do differently (pulling away, cold tyres) and the drift of the
# radius over the drive, none of which averages down like independent seconds.


def relative_scale(radii: tuple[float, float], source_radii: tuple[float, float]) -> float:
    """The WPM's relative change of rear radius, ``½ (r_rl / s_rl + r_rr / s_rr) − 1``."""
    return 0.5 * (radii[0] / source_radii[0] + radii[1] / source_radii[1]) - 1.0


def shrunk_radii(
    radii: tuple[float, float], source_radii: tuple[float, float], weight: float
) -> tuple[float, float] | None:
    """The rear radii moved ``weight`` of the way from the source calibration to ``radii``.

    Returns:
        ``radii`` themselves at weight 1, None (the source calibration: G alone) at 0.
    """
    if weight >= 1.0:
        return (float(radii[0]), float(radii[1]))
    if weight <= 0.0:
        return None
    return (
        source_radii[0] + weight * (radii[0] - source_radii[0]),
        source_radii[1] + weight * (radii[1] - source_radii[1]),
    )


def shrink_weight(prior_sd: float, sum_var_m2: float, distance_m: float) -> float:
    """How far to trust a refit: ``w = τ² / (τ² + V / D²)`` (the posterior mean's weight).

    Args:
        prior_sd: τ, the prior sd of the relative radius change (inf: no prior, w = 1).
        sum_var_m2: V, the variance of what the refit gets wrong over its distance, m².
        distance_m: D, the GNSS distance the refit rests on, m (<= 0: nothing, w = 0).

    Returns:
        w in [0, 1].
    """
    if distance_m <= 0 or prior_sd <= 0:
        return 0.0
    if math.isinf(prior_sd) or sum_var_m2 <= 0:
        return 1.0
    tau2 = prior_sd**2
    return tau2 / (tau2 + sum_var_m2 / distance_m**2)


def posterior_sd(prior_sd: float, sum_var_m2: float, distance_m: float) -> float:
    """The posterior sd of the relative radius change, ``√(w · V / D²)`` (τ when D <= 0)."""
    if distance_m <= 0:
        return prior_sd
    s2 = sum_var_m2 / distance_m**2
    if math.isinf(prior_sd):
        return math.sqrt(s2)
    tau2 = prior_sd**2
    return math.sqrt(tau2 * s2 / (tau2 + s2)) if tau2 + s2 > 0 else 0.0


@dataclass(frozen=True)
class ShrinkEvidence:
    """What the first k seconds of a drive can tell about its rear radius, and the prior.

    Measured by :func:`evidence_terms` and :func:`shrink_evidence` on drives whose
    answer is known (the refit on the rest of each drive).

    Attributes:
        role: what it was measured on: ``target_train`` (the car's own training drives,
            its own receiver) or ``source`` (the source car's drives).
        drives: the drives behind it.
        prior_sd: τ, the prior sd of a drive's relative radius change from G (the root
            mean square over the drives of their whole-drive refit, plus ``extra_prior_sd``
            in quadrature for a car the drives are not of).
        k_s: seconds from a drive's start at which V is known, increasing.
        sum_var_m2: V(k) at ``k_s``, m²: the mean over the drives of the square of what the
            first-k refit gets wrong over its own distance.
        n_drives: the drives behind each V(k).
    """

    role: str
    drives: tuple[str, ...]
    prior_sd: float
    k_s: tuple[int, ...]
    sum_var_m2: tuple[float, ...]
    n_drives: tuple[int, ...]

    def sum_var(self, k: float) -> float:
        """V(k): interpolated on ``k_s``; outside them proportional to k.

        Beyond the longest measured stretch the error of independent stretches adds (the
        GNSS error is correlated over tens of seconds, not minutes), so V grows like k;
        below the shortest the same rule overstates V (it grows faster at first), which
        errs towards G.
        """
        ks = np.asarray(self.k_s, np.float64)
        vs = np.asarray(self.sum_var_m2, np.float64)
        if k > ks[-1]:
            return float(vs[-1] * k / ks[-1])
        if k < ks[0]:
            return float(vs[0] * k / ks[0])
        return float(np.interp(k, ks, vs))

    def weight(self, k: float, distance_m: float) -> float:
        """:func:`shrink_weight` of a refit on a drive's first ``k`` seconds over ``distance_m``."""
        return shrink_weight(self.prior_sd, self.sum_var(k), distance_m)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready data (what ``evidence.json`` and a model bundle's metadata hold)."""
        return {
            "role": self.role,
            "drives": list(self.drives),
            "prior_sd": self.prior_sd,
            "k_s": list(self.k_s),
            "sum_var_m2": list(self.sum_var_m2),
            "n_drives": list(self.n_drives),
        }

    @classmethod
    def from_dict(cls, raw: Any, source: str) -> ShrinkEvidence:
        """Rebuild :meth:`to_dict`'s data.

        Raises:
            InputError: a field missing or malformed.
        """
        raw = raw if isinstance(raw, dict) else {}
        ks, vs, ns = (raw.get(key) for key in ("k_s", "sum_var_m2", "n_drives"))
        ok = (
            isinstance(raw.get("role"), str)
            and isinstance(raw.get("drives"), list)
            and isinstance(raw.get("prior_sd"), int | float)
            and raw["prior_sd"] >= 0
            and all(isinstance(a, list) and a for a in (ks, vs, ns))
            and len(ks) == len(vs) == len(ns)
            and all(isinstance(v, int | float) and v >= 0 for v in vs)
            and all(isinstance(k, int) and k > 0 for k in ks)
            and all(b > a for a, b in zip(ks, ks[1:], strict=False))
        )
        if not ok:
            raise InputError(
                [
                    Problem(
                        source,
                        None,
                        "evidence",
                        "role, drives, prior_sd >= 0 and matching lists k_s (increasing), "
                        "sum_var_m2 (>= 0) and n_drives",
                        repr(raw)[:120],
                    )
                ],
                f"{source}: the shrink recipe's evidence is malformed",
            )
        return cls(
            raw["role"],
            tuple(str(d) for d in raw["drives"]),
            float(raw["prior_sd"]),
            tuple(int(k) for k in ks),
            tuple(float(v) for v in vs),
            tuple(int(n) for n in ns),
        )


@dataclass(frozen=True)
class EvidenceTerms:
    """Per evidence drive, what :class:`ShrinkEvidence` averages (so a drive can be left out).

    Attributes:
        drives: the drives, in order.
        scale: (n,) each drive's whole-drive relative radius change under G (NaN: no fit).
        k_s: (K,) the seconds from a drive's start it is measured at.
        sq_error_m2: (n, K) ``((δ̂_k − δ_rest) · D_k)²`` of each drive at each k; NaN where the
            drive does not count (no refit of its first k s, or less than ``min_rest_s``
            seconds or no refit after them).
    """

    drives: tuple[str, ...]
    scale: np.ndarray
    k_s: np.ndarray
    sq_error_m2: np.ndarray


def evidence_grid(longest_s: int) -> np.ndarray:
    """The k at which V is measured: each second to 2 min, each 10 s to 10 min, then each minute."""
    grid = np.concatenate(
        [np.arange(1, 121), np.arange(130, 601, 10), np.arange(660, max(longest_s, 0) + 1, 60)]
    )
    return grid[grid <= longest_s]


def evidence_terms(
    drive: np.ndarray,
    k: np.ndarray,
    disp_gnss_m: np.ndarray,
    angle_rl_rad: np.ndarray,
    angle_rr_rad: np.ndarray,
    g_pred_m: np.ndarray,
    *,
    source_radii: tuple[float, float],
    min_speed_m_s: float,
    min_rest_s: int,
) -> EvidenceTerms:
    """Measure what the first k seconds of each drive tell about its radius, for every k.

    Per drive: the refit under G (:func:`rwhonet.features.calibration.refit`, what
    ``radius+G`` and ``shrink`` use) on its first k seconds (rank ``k_t < k``) and on the
    rest; the first one's error against the second, in relative scale, times the distance
    it rests on; and the whole drive's scale (the prior's spread). A drive counts at k
    while the rest is at least ``min_rest_s`` seconds long.

    Args:
        drive: (n,) the drive of every second (seconds of a drive in time order).
        k: (n,) each second's 0-based rank in its drive.
        disp_gnss_m: (n,) GNSS displacement per second, m.
        angle_rl_rad: (n,) rear-left wheel angle per second, rad.
        angle_rr_rad: (n,) rear-right wheel angle per second, rad.
        g_pred_m: (n,) G's prediction of the label per second, m.
        source_radii: the source calibration's rear radii (relative scales are to these).
        min_speed_m_s: the refit's moving-second threshold.
        min_rest_s: the fewest seconds after k a drive must have to count at k.

    Returns:
        The terms, one row per drive (in order of first appearance).
    """
    drive = np.asarray(drive)
    k = np.asarray(k)
    names = tuple(dict.fromkeys(drive.tolist()))
    lengths = [int((drive == d).sum()) for d in names]
    k_s = evidence_grid(max(lengths, default=0) - min_rest_s)
    scale = np.full(len(names), np.nan)
    sq = np.full((len(names), len(k_s)), np.nan)
    arrays = (disp_gnss_m, angle_rl_rad, angle_rr_rad, g_pred_m)
    for i, d in enumerate(names):
        mine = drive == d
        gnss, a_rl, a_rr, g = (np.asarray(a, np.float64)[mine] for a in arrays)
        rank = k[mine]
        whole = refit(gnss, a_rl, a_rr, min_speed_m_s, explained_m=g)
        if whole is None:
            continue
        scale[i] = relative_scale((whole.r_rl_m, whole.r_rr_m), source_radii)
        for j, kk in enumerate(k_s):
            first, rest = rank < kk, rank >= kk
            if rest.sum() < min_rest_s:
                break
            head = refit(gnss[first], a_rl[first], a_rr[first], min_speed_m_s, g[first])
            rest = refit(gnss[rest], a_rl[rest], a_rr[rest], min_speed_m_s, g[rest])
            if head is None or rest is None:
                continue
            err = relative_scale((head.r_rl_m, head.r_rr_m), source_radii) - relative_scale(
                (rest.r_rl_m, rest.r_rr_m), source_radii
            )
            sq[i, j] = (err * head.distance_m) ** 2
    return EvidenceTerms(names, scale, k_s, sq)


MIN_EVIDENCE_DRIVES = 2  # fewer drives at a k say nothing about V there


def prior_sd(scales: np.ndarray, others: np.ndarray | None = None, extra: float = 0.0) -> float:
    """τ: how far a new drive's relative radius change from G may lie, from drives' refits.

    ``τ² = mean(scales)² + s² + extra²``: the car's offset from G (the mean over its
    drives), the drive-to-drive spread s² (the sample variance, pooled with ``others``'
    when given: the spread of tyre pressure, wear, load and temperature between drives
    is a property of tyres both cars share, and a few drives of one car may not span it),
    and ``extra`` for what none of the drives can show (another car).

    Args:
        scales: (n,) whole-drive relative radius changes of the car's drives (n >= 2).
        others: another set of drives' changes, pooled into the spread only.
        extra: added in quadrature.
    """
    groups = [np.asarray(scales, np.float64)]
    if others is not None and len(others) >= 2:
        groups.append(np.asarray(others, np.float64))
    dof = sum(len(g) - 1 for g in groups)
    spread = sum(float(np.sum((g - g.mean()) ** 2)) for g in groups) / dof
    return math.sqrt(float(groups[0].mean()) ** 2 + spread + extra**2)


def shrink_evidence(
    terms: EvidenceTerms,
    role: str,
    *,
    exclude: str | None = None,
    spread_of: np.ndarray | None = None,
    extra_prior_sd: float = 0.0,
) -> ShrinkEvidence | None:
    """Average the terms over the drives into V(k) and τ (:class:`ShrinkEvidence`).

    Args:
        terms: :func:`evidence_terms`' output.
        role: what the drives are (``target_train``, ``source``).
        exclude: a drive to leave out (the drive being scored, when the evidence comes
            from drives that are scored too).
        spread_of: other drives' whole-drive scales, pooled into τ's drive-to-drive
            spread (:func:`prior_sd`; the source car's drives for the target car's).
        extra_prior_sd: added to τ in quadrature: the spread of a car the drives are not
            of (``adapt.shrink.unknown_car_sd``), 0 for the car's own drives.

    Returns:
        The evidence; None when fewer than :data:`MIN_EVIDENCE_DRIVES` drives have a
        whole-drive refit, or no k has that many drives.
    """
    keep = np.array([d != exclude for d in terms.drives], bool)
    scale = terms.scale[keep]
    sq = terms.sq_error_m2[keep]
    fitted = np.isfinite(scale)
    n = np.isfinite(sq).sum(axis=0)
    enough = n >= MIN_EVIDENCE_DRIVES
    if fitted.sum() < MIN_EVIDENCE_DRIVES or not enough.any():
        return None
    v = np.nansum(sq[:, enough], axis=0) / n[enough]
    others = None if spread_of is None else np.asarray(spread_of)[np.isfinite(spread_of)]
    return ShrinkEvidence(
        role,
        tuple(
            d
            for d, kept, f in zip(terms.drives, keep, np.isfinite(terms.scale), strict=True)
            if kept and f
        ),
        prior_sd(scale[fitted], others, extra_prior_sd),
        tuple(int(x) for x in terms.k_s[enough]),
        tuple(float(x) for x in v),
        tuple(int(x) for x in n[enough]),
    )


def shrink(
    base: WhONet,
    hparams: dict[str, Any],
    data: AdaptData,
    *,
    evidence: ShrinkEvidence,
    min_speed_m_s: float,
    source_radii: tuple[float, float],
    prior_radii: tuple[float, float] | None = None,
) -> AdaptResult:
    """The ``shrink`` recipe: ``radius+G``'s refit, shrunk towards G by what the m s can tell.

    The rear radii are refitted on the m seconds with G on top (:func:`radius_g`'s
    estimator) and moved from the source calibration only the posterior mean's share
    ``w`` of the way (the block comment above: ``w = τ² / (τ² + V(m) / D²)``, D the GNSS
    distance the refit rests on). Few or slow seconds, or a noisy receiver, give a small
    w and G; enough seconds give the refit. G is unchanged.

    Args:
        base: G-WhONet's network (kept as is).
        hparams: its hyperparameters.
        data: the m seconds (a drive's first ``len(data)`` seconds).
        evidence: V(k) and τ (:func:`shrink_evidence`).
        min_speed_m_s: seconds slower than this are left out of the refit.
        source_radii: the source calibration's rear radii.
        prior_radii: the prior's centre, when it is not G's radii: a car of another tyre
            size than the source car (``rwhonet recalibrate`` on a car the pipeline has
            no drives of: the source calibration scaled by the two cars' nominal radii).

    Returns:
        G with the shrunk radii (None: G alone, when no second moved fast enough or
        w = 0, and the prior is G's radii; the prior's radii otherwise); ``info`` has the
        weight, τ, the refit's own sd (√V / D), the posterior sd of the relative radius
        change, and the refit's, the prior's and the result's scale.
    """
    start = time.perf_counter()
    g_pred = predict(base, data.x, seq_len=hparams["seq_len"]).astype(np.float64)
    fit = refit(
        data.disp_gnss_m, data.angle_rl_rad, data.angle_rr_rad, min_speed_m_s, explained_m=g_pred
    )
    info: dict[str, Any] = {
        "radius_refit": fit is not None,
        "prior_sd": evidence.prior_sd,
        "evidence_drives": len(evidence.drives),
        "evidence_role": evidence.role,
    }
    centre = source_radii if prior_radii is None else prior_radii
    if prior_radii is not None:
        info["prior_scale"] = relative_scale(centre, source_radii)
    radii = None
    if fit is not None:
        v = evidence.sum_var(len(data))
        w = shrink_weight(evidence.prior_sd, v, fit.distance_m)
        refitted = (fit.r_rl_m, fit.r_rr_m)
        radii = shrunk_radii(refitted, centre, w)
        info.update(
            shrink_weight=w,
            fit_sd=math.sqrt(v) / fit.distance_m,
            posterior_sd=posterior_sd(evidence.prior_sd, v, fit.distance_m),
            refit_scale=relative_scale(refitted, source_radii),
            fit_distance_m=fit.distance_m,
        )
    if radii is None and prior_radii is not None:
        radii = (float(prior_radii[0]), float(prior_radii[1]))
    if fit is not None:
        info["scale"] = 0.0 if radii is None else relative_scale(radii, source_radii)
    return _radii_result(base, hparams, radii, start, info)


def recalibrate(
    recipe: str,
    base: WhONet,
    hparams: dict[str, Any],
    data: AdaptData,
    *,
    adapt: AdaptParams,
    seed: int,
    min_speed_m_s: float,
    evidence: ShrinkEvidence | None = None,
    source_radii: tuple[float, float] | None = None,
    prior_radii: tuple[float, float] | None = None,
) -> AdaptResult:
    """Run one recipe (any of ``adapt.recipes`` but the continuous ones, which run an inner one).

    ``shrink`` needs ``evidence`` and ``source_radii`` (and takes ``prior_radii``, its
    prior's centre when that is not G's radii: :func:`shrink`); the others ignore them.

    Raises:
        ValueError: for an unknown recipe, or ``shrink`` without its evidence.
    """
    if recipe == "shrink":
        if evidence is None or source_radii is None:
            raise ValueError("the shrink recipe needs its evidence and the source radii")
        return shrink(
            base,
            hparams,
            data,
            evidence=evidence,
            min_speed_m_s=min_speed_m_s,
            source_radii=source_radii,
            prior_radii=prior_radii,
        )
    if recipe == "paper":
        return fine_tune(base, hparams, data, adapt=adapt, seed=seed, trainable="all")
    if recipe == "head":
        return fine_tune(base, hparams, data, adapt=adapt, seed=seed, trainable="head")
    if recipe == "steps":
        return fine_tune_steps(base, hparams, data, adapt=adapt, seed=seed)
    if recipe == "ridge_head":
        return ridge_head(base, hparams, data, penalty=adapt.ridge_penalty)
    if recipe == "radius+G":
        return radius_g(base, hparams, data, min_speed_m_s=min_speed_m_s)
    raise ValueError(f"unknown recipe {recipe!r}")


def label_prediction(
    result: AdaptResult, data: AdaptData, source_radii: tuple[float, float]
) -> np.ndarray:
    """What a recalibrated model predicts for the label (GNSS − WPM with the source radii).

    The network's prediction, plus, when the recipe refitted the radii, the
    difference between the WPM with its radii and the source-calibrated one.

    Returns:
        (n,) float64 metres.
    """
    pred = predict(result.net, data.x, seq_len=result.hparams["seq_len"]).astype(np.float64)
    if result.radii is None:
        return pred
    return radius_corrected(pred, data.angle_rl_rad, data.angle_rr_rad, result.radii, source_radii)


def continuous_predictions(
    base: WhONet,
    hparams: dict[str, Any],
    data: AdaptData,
    k: np.ndarray,
    windows: np.ndarray,
    *,
    inner: str,
    penalty: float,
    window_s: int,
    min_speed_m_s: float,
    source_radii: tuple[float, float],
    evidence: ShrinkEvidence | None = None,
) -> np.ndarray:
    """The continuous recipes on one drive: recalibrate before every outage window.

    For a window whose first second has rank ``k0`` in the drive, the inner
    recipe is fitted on the seconds with ``k0 - window_s <= k < k0`` (every
    earlier second when ``window_s`` is 0), never on a second at or after the
    window's start, and predicts the window's seconds. Inner recipes:

    - ``ridge_head`` (the ``continuous`` recipe): G's head refitted in closed form;
    - ``radius+G``: the rear radii refitted under G;
    - ``shrink+ridge_head`` (the ``continuous_shrink`` recipe): first the rear radii as
      :func:`shrink` fits them (refitted under G, shrunk towards G by ``evidence`` at
      the number of seconds fitted on), then G's head refitted in closed form on what
      the WPM with those radii leaves, shrunk towards G's head by ``penalty`` per
      second. Both move further from G as the drive's seconds accumulate: the radius
      as V(k) / D² falls, the head as the data outweigh the penalty; so the model can
      learn more than a scale (the head on G's features: a speed- and load-dependent
      correction) where the seconds support it.

    The ridge fits accumulate ``AᵀA`` (and ``Aᵀy``) second by second, so a drive costs
    one pass over its seconds plus one small solve (and, with a radius, one refit) per
    window.

    Args:
        base: G-WhONet's network.
        hparams: its hyperparameters.
        data: every second of one drive, in time order.
        k: (n,) each second's 0-based rank in the drive (increasing).
        windows: (W, L) row indices into ``data`` of each window to predict.
        inner: ``ridge_head``, ``radius+G`` or ``shrink+ridge_head``.
        penalty: the ridge strength (``adapt.ridge_penalty``).
        window_s: fit on at most this many seconds before the window (0: all).
        min_speed_m_s: the radius refit's moving-second threshold.
        source_radii: the WPM's source calibration.
        evidence: V(k) and τ (``shrink+ridge_head`` only).

    Returns:
        (W, L) label predictions, metres; a window with no earlier second gets G's.
    """
    k = np.asarray(k)
    pred = np.empty(windows.shape, dtype=np.float64)
    g_pred = predict(base, data.x, seq_len=hparams["seq_len"]).astype(np.float64)
    order = np.argsort(k[windows[:, 0]], kind="stable")
    if inner == SHRINK_RIDGE and evidence is None:
        raise ValueError(f"continuous: {SHRINK_RIDGE} needs the shrink recipe's evidence")
    if inner in ("ridge_head", SHRINK_RIDGE):
        a = head_design(hidden_features(base, data.x))
        y = np.asarray(data.y, np.float64)
        theta0 = np.append(
            base.head.weight.detach().numpy()[0].astype(np.float64),
            float(base.head.bias.detach()[0]),
        )
        ata, aty = np.zeros((a.shape[1], a.shape[1])), np.zeros(a.shape[1])
        added = removed = 0  # rows [removed, added) are in the sums (k is increasing)
        for w in order:
            k0 = k[windows[w, 0]]
            while added < len(k) and k[added] < k0:
                ata += np.outer(a[added], a[added])
                aty += a[added] * y[added]
                added += 1
            while window_s and removed < added and k[removed] < k0 - window_s:
                ata -= np.outer(a[removed], a[removed])
                aty -= a[removed] * y[removed]
                removed += 1
            if added == removed:
                pred[w] = g_pred[windows[w]]
                continue
            rows = slice(removed, added)
            if inner == "ridge_head":
                theta = ridge_solve(a[rows], y[rows], theta0, penalty, gram=ata, moment=aty)
                pred[w] = a[windows[w]] @ theta
                continue
            a_rl, a_rr = data.angle_rl_rad, data.angle_rr_rad
            fit = refit(data.disp_gnss_m[rows], a_rl[rows], a_rr[rows], min_speed_m_s, g_pred[rows])
            radii = None
            if fit is not None:
                weight = evidence.weight(added - removed, fit.distance_m)
                radii = shrunk_radii((fit.r_rl_m, fit.r_rr_m), source_radii, weight)
            if radii is None:
                theta = ridge_solve(a[rows], y[rows], theta0, penalty, gram=ata, moment=aty)
                pred[w] = a[windows[w]] @ theta
                continue
            # what the WPM with the shrunk radii adds to the source-calibrated one
            by_radius = radius_corrected(0.0, a_rl[rows], a_rr[rows], radii, source_radii)
            theta = ridge_solve(a[rows], y[rows] - by_radius, theta0, penalty, gram=ata)
            win = windows[w]
            pred[w] = radius_corrected(a[win] @ theta, a_rl[win], a_rr[win], radii, source_radii)
        return pred
    if inner == "radius+G":
        for w in order:
            k0 = k[windows[w, 0]]
            before = (k < k0) & ((k >= k0 - window_s) if window_s else True)
            radii = refit_radii(
                data.disp_gnss_m[before],
                data.angle_rl_rad[before],
                data.angle_rr_rad[before],
                min_speed_m_s,
                explained_m=g_pred[before],
            )
            rows = windows[w]
            pred[w] = g_pred[rows]
            if radii is not None:
                pred[w] = radius_corrected(
                    pred[w], data.angle_rl_rad[rows], data.angle_rr_rad[rows], radii, source_radii
                )
        return pred
    raise ValueError(f"continuous: unknown inner recipe {inner!r}")

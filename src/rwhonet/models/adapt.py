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
  (the calibration's estimator) to what G on top leaves unexplained, G unchanged.

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
from rwhonet.features.calibration import refit_radii
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


@dataclass
class AdaptData:
    """A stretch of one drive to recalibrate on (or predict for): its samples and WPM inputs.

    Attributes:
        x: (n, seq_len, n_features) float32 windows.
        y: (n,) labels in metres (GNSS − WPM with the source calibration).
        disp_gnss_m: (n,) GNSS displacement per second, metres.
        angle_rl_rad: (n,) rear-left wheel angle per second (the WPM's mode), rad.
        angle_rr_rad: (n,) rear-right wheel angle per second, rad.
    """

    x: np.ndarray
    y: np.ndarray
    disp_gnss_m: np.ndarray
    angle_rl_rad: np.ndarray
    angle_rr_rad: np.ndarray

    def __len__(self) -> int:
        return len(self.y)

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
    seed_all(seed)
    net = copy.deepcopy(base)
    n_trainable, n_total = apply_trainable(net, trainable)
    loader = train_loader(ArrayDataset(x_t, y_t), batch_size=adapt.batch_size, seed=seed)
    optimizer = make_optimizer(net, adapt.lr)
    net.train()
    history = []
    for epoch in range(adapt.epochs):
        loss_m = train_epoch(net, optimizer, loader, adapt.batch_size)
        history.append({"epoch": epoch, "train_loss": loss_m, "val_loss": None})
    net.eval()
    return AdaptResult(
        net,
        {**hparams, "lr": adapt.lr, "batch_size": adapt.batch_size},
        None,
        history,
        time.perf_counter() - start,
        n_trainable,
        n_total,
    )


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
    seed_all(seed)
    net = copy.deepcopy(base)
    n_trainable, n_total = apply_trainable(net, "all")
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
    net.eval()
    return AdaptResult(
        net,
        {**hparams, "lr": adapt.lr, "batch_size": adapt.batch_size},
        None,
        history,
        time.perf_counter() - start,
        n_trainable,
        n_total,
        info={"steps": step, "best_step": best_step, "held_back_s": n_hold},
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
    return AdaptResult(
        copy.deepcopy(base).eval(),
        dict(hparams),
        radii,
        [],
        time.perf_counter() - start,
        2,
        count_parameters(base)[1] + 2,
        info={"radius_refit": radii is not None},
    )


def recalibrate(
    recipe: str,
    base: WhONet,
    hparams: dict[str, Any],
    data: AdaptData,
    *,
    adapt: AdaptParams,
    seed: int,
    min_speed_m_s: float,
) -> AdaptResult:
    """Run one recipe (any of ``adapt.recipes`` but ``continuous``, which runs its inner one).

    Raises:
        ValueError: for an unknown recipe.
    """
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
) -> np.ndarray:
    """The ``continuous`` recipe on one drive: recalibrate before every outage window.

    For a window whose first second has rank ``k0`` in the drive, the inner
    recipe (``ridge_head`` or ``radius+G``) is fitted on the seconds with
    ``k0 - window_s <= k < k0`` (every earlier second when ``window_s`` is 0),
    never on a second at or after the window's start, and predicts the window's
    seconds. The ridge fits accumulate ``AᵀA`` and ``Aᵀy`` second by second, so a
    drive costs one pass over its seconds plus one small solve per window.

    Args:
        base: G-WhONet's network.
        hparams: its hyperparameters.
        data: every second of one drive, in time order.
        k: (n,) each second's 0-based rank in the drive (increasing).
        windows: (W, L) row indices into ``data`` of each window to predict.
        inner: ``ridge_head`` or ``radius+G``.
        penalty: the ridge strength (``adapt.ridge_penalty``).
        window_s: fit on at most this many seconds before the window (0: all).
        min_speed_m_s: the radius refit's moving-second threshold.
        source_radii: the WPM's source calibration.

    Returns:
        (W, L) label predictions, metres; a window with no earlier second gets G's.
    """
    k = np.asarray(k)
    pred = np.empty(windows.shape, dtype=np.float64)
    g_pred = predict(base, data.x, seq_len=hparams["seq_len"]).astype(np.float64)
    order = np.argsort(k[windows[:, 0]], kind="stable")
    if inner == "ridge_head":
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
            theta = ridge_solve(a[rows], y[rows], theta0, penalty, gram=ata, moment=aty)
            pred[w] = a[windows[w]] @ theta
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

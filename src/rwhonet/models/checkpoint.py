"""One file format for every model (G, S and R, any network): its weights and hyperparameters.

``model.pt`` holds ``{"format", "hyper_parameters", "state_dict"}``: the
network's ``state_dict`` and the :data:`~rwhonet.models.loop.HPARAMS` a
:class:`~rwhonet.models.module.WhONetModule` is built from, so whoever loads a
model needs nothing else remembered (the G -> R hand-off of paper §2.6). A
network other than WhONet (``model.arch``) adds ``arch`` and its own
hyperparameters (:data:`~rwhonet.models.loop.ARCH_HPARAMS`), from which
:func:`load_whonet` rebuilds it; a WhONet's file has no ``arch`` and is the
paper network's as before; and,
for a model whose recipe refitted the WPM's rear radii (``radius+G``),
``wpm_radii`` (m/rad, rear left and right). The
file holds only tensors, numbers, strings and dicts, so it is read with
``torch.load(weights_only=True)``: loading a model never runs pickled code.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from rwhonet.errors import InputError, Problem
from rwhonet.models.loop import (
    ARCHS,
    DEFAULT_ARCH,
    arch_of,
    hparam_keys,
    net_from_hparams,
    saved_hparams,
)
from rwhonet.models.network import Network

FORMAT = "rwhonet.whonet/1"


def save_whonet(
    net: Network,
    hparams: Mapping[str, Any],
    path: Path,
    *,
    wpm_radii: tuple[float, float] | None = None,
) -> None:
    """Write a network and its hyperparameters.

    Args:
        net: the network.
        hparams: its :data:`~rwhonet.models.loop.HPARAMS` and, for a network other
            than WhONet, ``arch`` and that network's own (extra keys are dropped).
        path: the file to write.
        wpm_radii: the rear radii the model's WPM uses, when not the source calibration.
    """
    hyper_parameters = saved_hparams(hparams)
    torch.save(
        {
            "format": FORMAT,
            "hyper_parameters": hyper_parameters,
            "state_dict": {k: v.detach().clone() for k, v in net.state_dict().items()},
            **({"wpm_radii": [float(r) for r in wpm_radii]} if wpm_radii is not None else {}),
        },
        path,
    )


def load_wpm_radii(path: Path | str) -> tuple[float, float] | None:
    """The rear radii a model file's WPM uses, or None for the source calibration."""
    radii = torch.load(path, map_location="cpu", weights_only=True).get("wpm_radii")
    return None if radii is None else (float(radii[0]), float(radii[1]))


def load_whonet(path: Path | str) -> tuple[Network, dict[str, Any]]:
    """Read a model written by :func:`save_whonet`, in eval mode on the CPU.

    Args:
        path: the ``model.pt`` file.

    Returns:
        ``(net, hparams)``.

    Raises:
        InputError: when the file is not a model file (wrong format, an unknown
            network, missing hyperparameters, or weights that do not fit them).
    """
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # noqa: BLE001 - any unreadable file is reported the same way
        raise InputError(
            [Problem(str(path), None, None, "a WhONet model file (torch.save)", str(err)[:200])],
            "not a WhONet model file",
        ) from err
    problems = []
    if not isinstance(ckpt, dict) or ckpt.get("format") != FORMAT:
        found = ckpt.get("format") if isinstance(ckpt, dict) else type(ckpt).__name__
        problems.append(Problem(str(path), None, "format", repr(FORMAT), repr(found)))
    else:
        hp = ckpt.get("hyper_parameters")
        arch = arch_of(hp) if isinstance(hp, Mapping) else DEFAULT_ARCH
        if arch not in ARCHS:
            expected = f"one of {sorted(ARCHS)}"
            problems.append(Problem(str(path), None, "hyper_parameters.arch", expected, repr(arch)))
        elif not isinstance(hp, Mapping) or any(k not in hp for k in hparam_keys(arch)):
            problems.append(
                Problem(
                    str(path), None, "hyper_parameters", f"keys {hparam_keys(arch)}", repr(hp)[:120]
                )
            )
    if problems:
        raise InputError(problems, "not a WhONet model file")
    hparams = dict(ckpt["hyper_parameters"])
    net = net_from_hparams(hparams)
    try:
        net.load_state_dict(ckpt["state_dict"], strict=True)
    except (RuntimeError, TypeError) as err:
        raise InputError(
            [Problem(str(path), None, "state_dict", "weights of the saved shape", str(err)[:200])],
            "not a WhONet model file",
        ) from err
    net.eval()
    return net, hparams

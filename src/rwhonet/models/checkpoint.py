"""One file format for every model (G, S and R, any network): its weights and hyperparameters.

A model file holds the network's ``state_dict`` and the
:data:`~rwhonet.models.loop.HPARAMS` a :class:`~rwhonet.models.module.WhONetModule`
is built from, so whoever loads a model needs nothing else remembered (the
G -> R hand-off of paper §2.6). A network other than WhONet (``model.arch``)
adds ``arch`` and its own hyperparameters (:data:`~rwhonet.models.loop.ARCH_HPARAMS`),
from which :func:`load_whonet` rebuilds it; a WhONet's file has no ``arch`` and is
the paper network's as before; and, for a model whose recipe refitted the WPM's
rear radii (``radius+G``, ``shrink``), ``wpm_radii`` (m/rad, rear left and right).

The same content comes in two forms, told apart by the file's suffix:

- ``model.pt`` (what the pipeline's train and adapt stages write, DVC outputs):
  ``{"format", "hyper_parameters", "state_dict"[, "wpm_radii"]}`` by
  ``torch.save``. It holds only tensors, numbers, strings and dicts, so it is read
  with ``torch.load(weights_only=True)``, torch's restricted unpickler: no pickled
  code runs, but the format is still pickle's.
- ``model.safetensors`` (what a registered version carries,
  :mod:`rwhonet.tracking.registry`): the ``state_dict`` tensors in the
  `safetensors <https://huggingface.co/docs/safetensors>`_ format (a JSON header
  and raw little-endian tensor bytes) and the rest as JSON in its metadata, one
  entry :data:`META_KEY` = ``{"format", "hyper_parameters"[, "wpm_radii"]}``.
  It is read by the ``safetensors`` library alone: no pickle at all, no
  ``torch.load``. One metadata entry, not one per field, because the library
  writes its metadata entries in no fixed order: with one, the same model is
  the same bytes (and SHA-256) every time it is written.

:func:`to_safetensors` converts the first form into the second; both are read
with the same checks, and a file that fails them is an
:class:`~rwhonet.errors.InputError` naming the file and the part that is wrong.
"""

from __future__ import annotations

import json
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
SAFETENSORS_SUFFIX = ".safetensors"
META_KEY = "rwhonet"  # the safetensors metadata entry that holds everything but the weights
NOT_A_MODEL = "not a WhONet model file"


def save_whonet(
    net: Network,
    hparams: Mapping[str, Any],
    path: Path,
    *,
    wpm_radii: tuple[float, float] | None = None,
) -> None:
    """Write a network and its hyperparameters, in the form ``path``'s suffix names.

    Args:
        net: the network.
        hparams: its :data:`~rwhonet.models.loop.HPARAMS` and, for a network other
            than WhONet, ``arch`` and that network's own (extra keys are dropped).
        path: the file to write: ``*.safetensors`` in that format, any other
            suffix (``model.pt``) by ``torch.save``.
        wpm_radii: the rear radii the model's WPM uses, when not the source calibration.
    """
    hyper_parameters = saved_hparams(hparams)
    state_dict = {k: v.detach().clone() for k, v in net.state_dict().items()}
    radii = None if wpm_radii is None else [float(r) for r in wpm_radii]
    if Path(path).suffix == SAFETENSORS_SUFFIX:
        _save_safetensors(state_dict, hyper_parameters, radii, Path(path))
        return
    torch.save(
        {
            "format": FORMAT,
            "hyper_parameters": hyper_parameters,
            "state_dict": state_dict,
            **({"wpm_radii": radii} if radii is not None else {}),
        },
        path,
    )


def _save_safetensors(
    state_dict: Mapping[str, torch.Tensor],
    hyper_parameters: Mapping[str, Any],
    radii: list[float] | None,
    path: Path,
) -> None:
    from safetensors.torch import save_file

    meta = {"format": FORMAT, "hyper_parameters": _plain(hyper_parameters)}
    if radii is not None:
        meta["wpm_radii"] = radii
    save_file(
        {k: v.contiguous() for k, v in state_dict.items()},
        str(path),
        metadata={META_KEY: json.dumps(meta, sort_keys=True, separators=(",", ":"))},
    )


def _plain(hyper_parameters: Mapping[str, Any]) -> dict[str, Any]:
    """The hyperparameters as JSON's values (a numpy number as its Python number)."""
    return {k: v.item() if hasattr(v, "item") else v for k, v in hyper_parameters.items()}


def to_safetensors(src: Path | str, dst: Path | str) -> Path:
    """Write the model file ``src`` (either form) as ``dst`` (``*.safetensors``).

    ``src`` is read and checked as :func:`load_whonet` does, so only a valid model
    is converted; weights, hyperparameters and radii are carried over unchanged.

    Raises:
        InputError: ``src`` is not a model file.
        ValueError: ``dst`` does not end in ``.safetensors``.
    """
    dst = Path(dst)
    if dst.suffix != SAFETENSORS_SUFFIX:
        raise ValueError(f"{dst}: a safetensors model file ends in {SAFETENSORS_SUFFIX}")
    net, hparams = load_whonet(src)
    save_whonet(net, hparams, dst, wpm_radii=load_wpm_radii(src))
    return dst


def load_wpm_radii(path: Path | str) -> tuple[float, float] | None:
    """The rear radii a model file's WPM uses, or None for the source calibration.

    Raises:
        InputError: the file is not a model file (or its radii are not two numbers).
    """
    radii = _read(path, weights=False).get("wpm_radii")
    return None if radii is None else (float(radii[0]), float(radii[1]))


def load_whonet(path: Path | str) -> tuple[Network, dict[str, Any]]:
    """Read a model written by :func:`save_whonet` (either form), in eval mode on the CPU.

    Args:
        path: the ``model.pt`` or ``model.safetensors`` file.

    Returns:
        ``(net, hparams)``.

    Raises:
        InputError: when the file is not a model file (unreadable, wrong format, an
            unknown network, missing hyperparameters, or weights that do not fit them).
    """
    ckpt = _read(path, weights=True)
    hparams = dict(ckpt["hyper_parameters"])
    net = net_from_hparams(hparams)
    try:
        net.load_state_dict(ckpt["state_dict"], strict=True)
    except (RuntimeError, TypeError) as err:
        raise InputError(
            [Problem(str(path), None, "state_dict", "weights of the saved shape", str(err)[:200])],
            NOT_A_MODEL,
        ) from err
    net.eval()
    return net, hparams


def _read(path: Path | str, *, weights: bool) -> dict[str, Any]:
    """A model file's content as ``torch.save``'s dict, checked but for the weights' shapes.

    ``weights=False`` reads a safetensors file's header alone (its ``state_dict``
    is then empty).
    """
    if Path(path).suffix == SAFETENSORS_SUFFIX:
        ckpt = _read_safetensors(Path(path), weights)
    else:
        try:
            ckpt = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as err:  # noqa: BLE001 - any unreadable file is reported the same way
            expected = "a WhONet model file (torch.save)"
            raise InputError(
                [Problem(str(path), None, None, expected, str(err)[:200])], NOT_A_MODEL
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
        radii = ckpt.get("wpm_radii")
        if radii is not None and not _two_numbers(radii):
            problems.append(
                Problem(str(path), None, "wpm_radii", "two radii in m/rad", repr(radii)[:120])
            )
    if problems:
        raise InputError(problems, NOT_A_MODEL)
    return ckpt


def _two_numbers(value: Any) -> bool:
    return (
        isinstance(value, list | tuple)
        and len(value) == 2
        and all(isinstance(r, int | float) and not isinstance(r, bool) for r in value)
    )


def _read_safetensors(path: Path, weights: bool) -> dict[str, Any]:
    """A safetensors model file as ``torch.save``'s dict; read by ``safetensors`` alone.

    Raises:
        InputError: not a safetensors file, or no :data:`META_KEY` JSON object in
            its metadata (what is in that object is checked by :func:`_read`).
    """
    from safetensors import safe_open

    try:
        with safe_open(str(path), framework="pt", device="cpu") as f:
            header = f.metadata() or {}
            state_dict = {k: f.get_tensor(k) for k in f.keys()} if weights else {}
    except Exception as err:  # noqa: BLE001 - any unreadable file is reported the same way
        raise InputError(
            [Problem(str(path), None, None, "a WhONet model file (safetensors)", str(err)[:200])],
            NOT_A_MODEL,
        ) from err
    text = header.get(META_KEY)
    try:
        meta = json.loads(text) if text is not None else None
    except json.JSONDecodeError:
        meta = None
    if not isinstance(meta, dict):
        found = "no such entry" if text is None else repr(text[:120])
        raise InputError(
            [
                Problem(
                    str(path),
                    None,
                    f"metadata.{META_KEY}",
                    f'a JSON object {{"format": {FORMAT!r}, "hyper_parameters": ...}}',
                    found,
                )
            ],
            NOT_A_MODEL,
        )
    return {**meta, "state_dict": state_dict}

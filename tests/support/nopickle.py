"""Make every pickle loader fail the test that calls it (the registry's no-pickle checks)."""

from __future__ import annotations

import pickle

import cloudpickle
import torch


def refuse(*args, **kwargs):
    raise AssertionError("a pickle was loaded")


def forbid_pickle(monkeypatch) -> None:
    """torch.load, pickle's and cloudpickle's loaders raise for the rest of the test."""
    for module, name in [
        (torch, "load"),
        (torch.serialization, "load"),
        (pickle, "load"),
        (pickle, "loads"),
        (pickle, "Unpickler"),
        (cloudpickle, "load"),
        (cloudpickle, "loads"),
    ]:
        monkeypatch.setattr(module, name, refuse)

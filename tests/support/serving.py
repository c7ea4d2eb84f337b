"""A served base model and simulated ci-profile drives, for the serving, registry and CLI tests.

:func:`base_bundle` writes a model bundle (``model.safetensors``, ``model.onnx``,
``rwhonet.json``), beside the ``source.pt`` it is made from, of a freshly
initialised WhONet with a fixed scaler and the source car's nominal radius as
its calibration: what the pipeline registers as ``whonet-G``, without training
one. :func:`ci_fleet` simulates the ``ci`` profile's drives (the same files
``make variant SET=sim.profile=ci`` feeds the pipeline).
"""

from __future__ import annotations

from pathlib import Path

import torch

from rwhonet.config import load_params
from rwhonet.features.scaling import MinMaxScaler
from rwhonet.models.checkpoint import save_whonet
from rwhonet.models.loop import net_from_hparams
from rwhonet.models.network import Network
from rwhonet.serve.bundle import make_meta, write_bundle

RADIUS_M = 0.294  # the fiesta's nominal radius: the base model's "source calibration"
SCALER = MinMaxScaler("global", (0.0,) * 4, (110.0,) * 4, ("test",), 1)
HPARAMS = {
    "n_features": 40,
    "hidden": 72,
    "layers": 1,
    "dropout": 0.05,
    "seq_len": 1,
    "lr": 0.0007,
    "batch_size": 128,
}


def base_net(seed: int = 0, seq_len: int = 1, arch: str = "whonet") -> tuple[Network, dict]:
    """A network with its default initial weights and a head that predicts metres, not zeros.

    ``arch`` ``whonet`` (the default: a WhONet's hyperparameters, no ``arch`` key),
    ``gru`` or ``tcn`` (``model.arch``).
    """
    hparams = {**HPARAMS, "seq_len": seq_len}
    if arch != "whonet":
        hparams.update(arch=arch, channels=16)
    torch.manual_seed(seed)
    net = net_from_hparams(hparams)
    with torch.no_grad():
        net.head.weight.mul_(0.05)
        net.head.bias.fill_(0.02)
    net.eval()
    return net, hparams


def base_bundle(
    folder: Path,
    seed: int = 0,
    wpm_radii: tuple[float, float] | None = None,
    evidence: dict | None = None,
    *,
    arch: str = "whonet",
    seq_len: int = 1,
) -> dict:
    """Write a bundle of :func:`base_net` into ``folder/bundle``; return its artifacts.

    The model file it is made from, as the pipeline writes one, is ``folder/source.pt``.

    ``evidence``: what the shrink recipe sizes its update by (``evidence.json``'s layout).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    net, hparams = base_net(seed, seq_len, arch)
    save_whonet(net, hparams, folder / "source.pt", wpm_radii=wpm_radii)
    meta = make_meta(
        hparams,
        SCALER.to_dict(),
        {"r_rl_m": RADIUS_M, "r_rr_m": RADIUS_M},
        "integrated",
        None,
        {"name": "whonet-G", "model": "G"},
        evidence,
    )
    return write_bundle(folder / "source.pt", meta, folder / "bundle")


def ci_fleet(out_dir: Path) -> Path:
    """Simulate the ``ci`` profile's drives into ``out_dir/<role>/<drive>.csv``."""
    from rwhonet.sim import simulate_fleet

    params = load_params(overrides={"sim.profile": "ci"})
    simulate_fleet(params, Path(out_dir))
    return Path(out_dir)


def wavy_drive(duration_s: float = 400.0, seed: int = 0, t0_s: float = 45000.0):
    """A synthetic 10 Hz drive (canonical columns) at a wavy speed, noisy GNSS and wheels."""
    import numpy as np

    from rwhonet.data import canonical as c
    from support.synthetic import build_drive, wavy_speed

    df = build_drive(
        wavy_speed(duration_s, 12.0, 4.0, 60.0, t0_s=t0_s),
        gnss_sigma_m=0.2,
        wheel_sigma_rad_s=0.05,
        seed=seed,
    )
    df[c.N_SATS] = np.full(len(df), 9.0)
    return df


def write_drive(path: Path, duration_s: float = 400.0, seed: int = 0) -> Path:
    """:func:`wavy_drive` as an IO-VNBD CSV."""
    from support.drives import write_iovnbd

    return write_iovnbd(wavy_drive(duration_s, seed), Path(path))


def predict_args(bundle: dict, drive, out, *extra: str) -> list[str]:
    """``rwhonet predict``'s arguments for a bundle's ONNX model, a drive and an output."""
    return [
        "predict",
        "--model",
        str(bundle["model_onnx"]),
        "--drive",
        str(drive),
        "--output",
        str(out),
        *extra,
    ]

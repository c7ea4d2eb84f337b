"""The lightning-free core: the lean fine-tune is the Lightning fine-tune, bit for bit."""

from __future__ import annotations

import json
import random
import subprocess
import sys
from dataclasses import replace

import lightning as L
import numpy as np
import pytest
import torch

from rwhonet.errors import InputError
from rwhonet.models import core
from rwhonet.models.core import (
    ArrayDataset,
    EpochLoss,
    fine_tune_lean,
    make_optimizer,
    predict,
    read_checkpoint,
    save_checkpoint_lean,
    seed_all,
    train_block,
    train_loader,
)
from rwhonet.models.datamodule import WhONetDataModule
from rwhonet.models.module import WhONetModule
from rwhonet.models.train import fine_tune, fit, load_module, save_checkpoint
from rwhonet.models.whonet import WhONet


@pytest.fixture(scope="module")
def g_ckpt(tmp_path_factory, linear_data):
    """A small G-WhONet checkpoint written by the Lightning path (hidden 16, dropout 0.05)."""
    from rwhonet.config import ModelParams, TrainParams

    x, y = linear_data
    model = ModelParams(hidden=16, layers=1, dropout=0.05, seq_len=1)
    train = TrainParams(epochs=2, batch_size=64, lr=0.01, val_fraction=0.1, num_threads=1)
    path = tmp_path_factory.mktemp("g") / "model.ckpt"
    save_checkpoint(fit(x, y, model=model, train=train, seed=1), path)
    return path


def _weights_equal(a: torch.nn.Module, b: torch.nn.Module) -> bool:
    sa, sb = a.state_dict(), b.state_dict()
    return list(sa) == list(sb) and all(torch.equal(sa[k], sb[k]) for k in sa)


# Recipes that exercise one block per epoch with a partial slice, several blocks per
# epoch, one-sample slices, and the two partial freeze policies.
RECIPES = [
    pytest.param({"epochs": 6, "batch_size": 128}, 50, 64, id="one-slice"),
    pytest.param({"epochs": 3, "batch_size": 16}, 90, 2, id="blocks-and-partial-slice"),
    pytest.param({"epochs": 4, "batch_size": 16, "trainable": "head"}, 40, 64, id="head"),
    pytest.param({"epochs": 4, "batch_size": 8, "trainable": "rnn"}, 30, 1, id="rnn"),
]


@pytest.mark.parametrize(("recipe", "m", "steps_per_block"), RECIPES)
def test_lean_fine_tune_is_bit_identical_to_lightning(
    g_ckpt, linear_data, adapt_params, recipe, m, steps_per_block
):
    x, y = linear_data
    adapt = replace(adapt_params, **recipe)
    kw = {"adapt": adapt, "seed": 11, "steps_per_block": steps_per_block}
    lit = fine_tune(g_ckpt, x[:m], y[:m] + 0.5, **kw)
    lean = fine_tune_lean(g_ckpt, x[:m], y[:m] + 0.5, **kw)
    assert _weights_equal(lit.module.net, lean.net)
    assert lit.history == lean.history
    assert len(lean.history) == adapt.epochs and lean.history[0]["val_loss"] is None
    assert (lit.n_trainable, lit.n_total) == (lean.n_trainable, lean.n_total)
    assert lean.hparams == dict(lit.module.hparams)
    np.testing.assert_array_equal(predict(lit.module, x), predict(lean.net, x))
    assert not lean.net.training
    # and it really moved away from G (else equality would prove little)
    g = WhONetModule.load_from_checkpoint(g_ckpt)
    assert not _weights_equal(g.net, lean.net)


def test_a_different_seed_gives_different_weights(g_ckpt, linear_data, adapt_params):
    x, y = linear_data
    a, b = (fine_tune_lean(g_ckpt, x[:40], y[:40], adapt=adapt_params, seed=s) for s in (5, 6))
    assert not _weights_equal(a.net, b.net)  # dropout and shuffling follow the seed


def test_lean_checkpoint_is_what_lightning_writes_but_loops(
    tmp_path, g_ckpt, linear_data, adapt_params
):
    x, y = linear_data
    adapt = replace(adapt_params, lr=0.003, batch_size=32)
    lit = fine_tune(g_ckpt, x[:60], y[:60], adapt=adapt, seed=2)
    lean = fine_tune_lean(g_ckpt, x[:60], y[:60], adapt=adapt, seed=2)
    save_checkpoint(lit, tmp_path / "lit.ckpt")
    save_checkpoint_lean(lean, tmp_path / "r" / "lean.ckpt")
    a = torch.load(tmp_path / "lit.ckpt", weights_only=True)
    b = torch.load(tmp_path / "r" / "lean.ckpt", weights_only=True)
    assert set(a) - set(b) == {"loops"} and set(b) <= set(a)
    for key in set(b) - {"state_dict"}:
        assert a[key] == b[key], key
    assert b["hyper_parameters"]["lr"] == 0.003 and b["hyper_parameters"]["batch_size"] == 32
    assert b["epoch"] == adapt.epochs
    assert list(a["state_dict"]) == list(b["state_dict"])
    assert all(torch.equal(a["state_dict"][k], b["state_dict"][k]) for k in a["state_dict"])
    # Lightning loads it: same hyperparameters, weights and predictions as the Lightning run.
    loaded = WhONetModule.load_from_checkpoint(tmp_path / "r" / "lean.ckpt")
    assert dict(loaded.hparams) == dict(lit.module.hparams)
    assert _weights_equal(loaded, lit.module)
    np.testing.assert_array_equal(
        predict(load_module(tmp_path / "r" / "lean.ckpt"), x), predict(lit.module, x)
    )


# Runs in a fresh interpreter, as a DVC stage does; argv[1] is a JSON job description.
LEAN_CHILD = """
import json, sys
import numpy as np
import rwhonet.models.core as core
from rwhonet.config import AdaptParams

job = json.loads(sys.argv[1])
x, y = np.load(job["x"]), np.load(job["y"])
adapt = AdaptParams(m_grid=[10], chosen_m=10, **job["recipe"])
r = core.fine_tune_lean(job["g"], x, y, adapt=adapt, seed=job["seed"])
core.save_checkpoint_lean(r, job["ckpt"])
np.save(job["pred"], core.predict(r.net, x))
with open(job["history"], "w") as f:
    json.dump(r.history, f)
loaded = sorted(m for m in sys.modules if m.partition(".")[0] in ("lightning", "pytorch_lightning"))
assert not loaded, loaded
"""


def test_lean_path_needs_no_lightning_and_matches_it_across_processes(
    tmp_path, g_ckpt, linear_data, adapt_params
):
    x, y = linear_data
    np.save(tmp_path / "x.npy", x[:70])
    np.save(tmp_path / "y.npy", y[:70])
    recipe = {"epochs": 5, "batch_size": 16, "lr": 0.01, "trainable": "all"}
    files = {k: str(tmp_path / f) for k, f in
             [("x", "x.npy"), ("y", "y.npy"), ("ckpt", "lean.ckpt"), ("pred", "pred.npy"),
              ("history", "history.json")]}  # fmt: skip
    job = {**files, "g": str(g_ckpt), "recipe": recipe, "seed": 3}
    done = subprocess.run(
        [sys.executable, "-c", LEAN_CHILD, json.dumps(job)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    lit = fine_tune(g_ckpt, x[:70], y[:70], adapt=replace(adapt_params, **recipe), seed=3)
    assert _weights_equal(load_module(files["ckpt"]), lit.module)
    np.testing.assert_array_equal(np.load(files["pred"]), predict(lit.module, x[:70]))
    with open(files["history"]) as f:
        assert json.load(f) == lit.history


def test_train_loader_is_the_datamodules_order(linear_data):
    x, y = linear_data
    dm = WhONetDataModule(x, y, batch_size=32, seed=9, steps_per_block=3)
    ours = train_loader(ArrayDataset(x, y), batch_size=32, seed=9, steps_per_block=3)
    theirs = dm.train_dataloader()
    for _ in range(3):  # the generator advances from epoch to epoch in both
        a, b = [yb for _, yb in ours], [yb for _, yb in theirs]
        assert [len(t) for t in a] == [96] * 12 + [1200 - 12 * 96]
        assert all(torch.equal(p, q) for p, q in zip(a, b, strict=True))
    with pytest.raises(ValueError):
        train_loader(ArrayDataset(x, y), batch_size=0, seed=0)


def test_train_block_steps_once_per_slice_in_order():
    torch.manual_seed(0)
    net = WhONet(n_features=3, hidden=4, dropout=0.0)
    opt = make_optimizer(net, lr=0.01)
    x, y = torch.rand(37, 1, 3), torch.rand(37)
    first_loss = core.batch_mae(net, x[:16], y[:16]).detach()
    losses = EpochLoss()
    train_block(net, opt, x, y, 16, losses)
    assert losses.sizes == [16, 16, 5]  # ceil(37 / 16) slices, the last one partial
    assert torch.equal(losses.losses[0], first_loss)  # each loss is taken before its step
    assert all(int(opt.state[p]["step"]) == 3 for p in net.parameters())


def test_frozen_parameters_are_left_out_of_the_optimizer():
    net = WhONet(hidden=3)
    core.apply_trainable(net, "head")
    params = make_optimizer(net, 0.002).param_groups[0]["params"]
    assert [id(p) for p in params] == [id(net.head.weight), id(net.head.bias)]


def test_epoch_loss_is_sample_weighted_mean():
    acc = EpochLoss()
    acc.add(torch.tensor(1.0), 3)
    acc.add(torch.tensor(4.0, requires_grad=True), 1)
    assert acc.pop_mean() == pytest.approx((3 * 1.0 + 1 * 4.0) / 4)
    assert acc.pop_mean() is None  # reset for the next epoch


def test_seed_all_seeds_like_lightning():
    def draws() -> tuple:
        return random.random(), np.random.random(), torch.rand(3).tolist()  # noqa: NPY002

    L.seed_everything(1234, verbose=False)
    expected = draws()
    seed_all(1234)
    assert draws() == expected
    for bad in (-1, 2**32):
        with pytest.raises(ValueError):
            seed_all(bad)


def test_read_checkpoint_names_what_is_missing(tmp_path, g_ckpt):
    ckpt = torch.load(g_ckpt, weights_only=True)
    del ckpt["hyper_parameters"]["seq_len"]
    torch.save(ckpt, tmp_path / "no_seq_len.ckpt")
    with pytest.raises(InputError) as err:
        read_checkpoint(tmp_path / "no_seq_len.ckpt")
    assert err.value.problems[0].column == "hyper_parameters"
    assert "seq_len" in err.value.problems[0].found
    torch.save({"weights": 1}, tmp_path / "other.ckpt")
    with pytest.raises(InputError) as err:
        read_checkpoint(tmp_path / "other.ckpt")
    assert [p.column for p in err.value.problems] == ["state_dict", "hyper_parameters"]


def test_lean_fine_tune_rejects_inputs_that_do_not_fit_g(g_ckpt, linear_data, adapt_params):
    x, y = linear_data
    with pytest.raises(InputError, match="39"):
        fine_tune_lean(g_ckpt, x[:50, :, :39], y[:50], adapt=adapt_params, seed=1)
    with pytest.raises(InputError, match="at least one sample"):
        fine_tune_lean(g_ckpt, x[:0], y[:0], adapt=adapt_params, seed=1)
    with pytest.raises(ValueError, match="lr"):
        fine_tune_lean(g_ckpt, x[:50], y[:50], adapt=replace(adapt_params, lr=0.0), seed=1)


def test_predict_checks_a_bare_networks_inputs(linear_data):
    x, _ = linear_data
    net = WhONet(hidden=4)
    assert predict(net, x[:5], seq_len=1).shape == (5,)
    with pytest.raises(InputError, match="40 features"):
        predict(net, x[:5, :, :30])
    with pytest.raises(InputError, match="2 time steps"):
        predict(net, x[:5], seq_len=2)

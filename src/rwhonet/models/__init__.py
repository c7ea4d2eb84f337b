"""WhONet models: the networks, their training loop, Lightning wrapper, recalibration and files.

- ``network``: what every network offers (one prediction per window, the head's inputs);
- ``whonet``: the paper's network (§2.3-2.5): a simple RNN and a linear head (the default);
- ``gru``, ``tcn``: networks with temporal context over the window (``model.arch``);
- ``loop``: the training update, once (MAE, Adamax, seeded mini-batches), for
  Lightning and for recalibration alike, and which network ``model.arch`` builds;
- ``module``, ``datamodule``: the LightningModule and DataModule G and S train with;
- ``train``: fitting G or S with a Lightning Trainer (``epoch_log``: plain per-epoch
  lines where no bar is drawn);
- ``vectorised``: every seed of a network trained at once, each as ``train`` trains it;
- ``freeze``: the explicit freeze policy of a fine-tune (which weights change);
- ``adapt``: R-WhONet's recalibration recipes and their label predictions;
- ``checkpoint``: the one model file (weights and hyperparameters, loaded without pickle);
- ``onnx``: a model as an ONNX graph, what ``rwhonet predict`` runs without torch.

Submodules are imported explicitly (``from rwhonet.models.train import fit``):
importing Lightning costs several seconds, which code that only needs the
network (``rwhonet.models.whonet``) should not pay.
"""

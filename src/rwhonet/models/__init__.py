"""WhONet models: the network, its training loop, Lightning wrapper, recalibration and files.

- ``whonet``: the network (paper §2.3-2.5): a simple RNN and a linear head;
- ``loop``: the training update, once (MAE, Adamax, seeded mini-batches), for
  Lightning and for recalibration alike;
- ``module``, ``datamodule``: the LightningModule and DataModule G and S train with;
- ``train``: fitting G or S with a Lightning Trainer (``epoch_log``: plain per-epoch
  lines where no bar is drawn);
- ``freeze``: the explicit freeze policy of a fine-tune (which weights change);
- ``adapt``: R-WhONet's recalibration recipes and their label predictions;
- ``checkpoint``: the one model file (weights and hyperparameters, loaded without pickle);
- ``onnx``: a model as an ONNX graph, what ``rwhonet predict`` runs without torch.

Submodules are imported explicitly (``from rwhonet.models.train import fit``):
importing Lightning costs several seconds, which code that only needs the
network (``rwhonet.models.whonet``) should not pay.
"""

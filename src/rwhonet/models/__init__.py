"""WhONet models: the network, its LightningModule and DataModule, the freeze policy, entry points.

Submodules are imported explicitly (``from rwhonet.models.train import fit``):
importing Lightning costs several seconds, which code that only needs the
network (``rwhonet.models.whonet``) should not pay.
"""

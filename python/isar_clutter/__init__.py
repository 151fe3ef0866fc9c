"""isar_clutter: multiscale statistics and synthesis of ISAR clutter on numpy arrays.

The analysis, the fit and the generation of the isar-clutter command line, in process:

    import numpy as np, isar_clutter as ic
    maps = ic.analyse(stack, levels=3)          # stack: [N, H, W] complex or real
    model = ic.fit(stack, method="method2")     # or ic.Model.load("models/m2")
    x = model.generate(1000, seed=7)            # complex64 [1000, H, W]
    model.save("models/m2")                     # a model folder the command line reads

Sample ``i`` of a seed is byte for byte the one ``isar-clutter generate --seed`` writes,
whether drawn alone, in blocks or by the command line. ``isar_clutter.torch.ClutterDataset``
streams unlimited clutter into a PyTorch DataLoader (importing ``isar_clutter`` does not need
torch).
"""

from ._native import Model, __version__, analyse, epoch_seed, fit

__all__ = ["Model", "__version__", "analyse", "epoch_seed", "fit"]

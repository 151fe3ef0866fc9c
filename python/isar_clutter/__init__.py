"""isar_clutter: multiscale statistics and synthesis of ISAR clutter on numpy arrays.

The analysis, the fit and the generation of the isar-clutter command line, in process:

    import numpy as np, isar_clutter as ic
    maps = ic.analyse(stack, levels=3)          # stack: [N, H, W] complex or real
    model = ic.fit(stack, method="method2")     # or ic.Model.load("models/m2")
    x = model.generate(1000, seed=7)            # complex64 [1000, H, W]
    model.save("models/m2")                     # a model folder the command line reads

``isar_clutter.load`` reads radar scenes in the field's formats into the same arrays (UAVSAR
``.slc`` stacks; checked as the command line's dataset kinds check them).

Sample ``i`` of a seed is byte for byte the one ``isar-clutter generate --seed`` writes,
whether drawn alone, in blocks or by the command line. ``isar_clutter.torch.ClutterDataset``
streams unlimited clutter into a PyTorch DataLoader (importing ``isar_clutter`` does not need
torch).
"""

import os
from pathlib import Path
from typing import Optional, Sequence, Tuple, Union

from ._native import Model, __version__, analyse, epoch_seed, fit, load_uavsar

__all__ = ["Model", "__version__", "analyse", "epoch_seed", "fit", "load"]

PathArg = Union[str, "os.PathLike[str]"]


def _paths(p: Union[PathArg, Sequence[PathArg], None]) -> list:
    if p is None:
        return []
    if isinstance(p, (str, os.PathLike)):
        return [os.fspath(p)]
    return [os.fspath(x) for x in p]


def load(
    path: Union[PathArg, Sequence[PathArg]],
    *,
    annotation: Union[PathArg, Sequence[PathArg], None] = None,
    window: Optional[Tuple[int, int, int, int]] = None,
):
    """A stack of radar images as a numpy array ``[N, H, W]``, ready for ``analyse`` and ``fit``.

    ``path``: one file or a list of coregistered ones. Read by their kind:

    - UAVSAR single-look complex scenes (``.slc``, little-endian complex64) with their
      annotation (``annotation``: one for all, one per scene, or none: each scene's own,
      ``<name>.ann`` beside ``<name>_s<k>_1x1.slc``); every scene is one sample, read in
      ``window`` ``(row, col, rows, cols)`` (default: the whole scene). complex64.

    A bad file raises ``ValueError`` naming the field (``slc[i]``, ``annotation``, ``window``)
    and the file, as ``kind: uavsar`` in a spec does.
    """
    paths = _paths(path)
    kinds = {Path(p).suffix.lower() for p in paths}
    if kinds == {".slc"}:
        return load_uavsar(paths, _paths(annotation), window)
    raise ValueError(
        f"load reads UAVSAR .slc files; {sorted(kinds) or 'no path'} given "
        "(other formats: the command line's dataset kinds, docs/spec.md)"
    )

"""Unlimited clutter for PyTorch: ``ClutterDataset``, an ``IterableDataset`` of generated samples.

The stream of a seed is cut into blocks of ``block`` samples (block ``b`` holds samples
``b * block ..``). Distributed rank ``r`` of ``world_size`` takes blocks ``r, r + world_size,
...``; within a rank, DataLoader worker ``k`` of ``W`` takes every ``W``-th of the rank's blocks,
starting at its ``k``-th. A DataLoader hands out its workers' batches in turn, so with
``batch_size == block`` every rank sees its blocks in order for any ``num_workers``, and a single
process (one rank) sees the samples ``0, 1, 2, ...`` of the command line's ``generate --seed``.
``set_epoch(e)`` gives epoch ``e`` the stream of ``epoch_seed(seed, e)``: fresh samples, the same
on every run.

    from torch.utils.data import DataLoader
    from isar_clutter.torch import ClutterDataset
    data = ClutterDataset("models/m2", seed=1, block=64)
    for batch in DataLoader(data, batch_size=64, num_workers=2):
        ...  # complex64 tensors [64, H, W], forever (samples=None)
"""

from __future__ import annotations

import os
from typing import Callable, Iterator, Optional, Tuple, Union

import torch
from torch.utils.data import IterableDataset, get_worker_info

from . import Model, epoch_seed

__all__ = ["ClutterDataset"]


def _count(name: str, value: Optional[int], least: int) -> Optional[int]:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{name} must be an int, not {type(value).__name__}")
    if value < least:
        raise ValueError(f"{name} must be at least {least}, not {value}")
    return value


class ClutterDataset(IterableDataset):
    """Samples generated from a synthesis model, streamed (see the module's docstring).

    Args:
        model: a ``Model``, or the path of a model folder.
        seed: the generation's seed (``isar-clutter generate --seed``).
        samples: how many samples in all (over every rank and worker); ``None``: unlimited.
        transform: applied to every sample (a complex64 tensor ``[H, W]``) before it is yielded.
        block: samples generated at once; the unit that ranks and workers share out.
        rank, world_size: this process's share in distributed training (default: from
            ``torch.distributed`` when it is initialised, else one process).
        threads: generation threads (default: 1 in a DataLoader worker, all cores otherwise).
    """

    def __init__(
        self,
        model: Union[Model, str, os.PathLike],
        seed: int,
        samples: Optional[int] = None,
        transform: Optional[Callable[[torch.Tensor], object]] = None,
        block: int = 64,
        rank: Optional[int] = None,
        world_size: Optional[int] = None,
        threads: Optional[int] = None,
    ) -> None:
        super().__init__()
        if not isinstance(model, Model):
            model = Model.load(os.fspath(model))
        self.model = model
        self.seed = _count("seed", seed, 0)
        self.samples = _count("samples", samples, 0)
        self.transform = transform
        self.block = _count("block", block, 1)
        self.threads = _count("threads", threads, 1)
        if (rank is None) != (world_size is None):
            raise ValueError("rank and world_size go together")
        self.world_size = _count("world_size", world_size, 1)
        self.rank = _count("rank", rank, 0)
        if self.rank is not None and self.rank >= self.world_size:
            raise ValueError(f"rank {self.rank} is not below world_size {self.world_size}")
        self.epoch = 0

    def set_epoch(self, epoch: int) -> None:
        """Draws epoch ``epoch``'s samples from now on (the stream of ``epoch_seed(seed, epoch)``)."""
        self.epoch = _count("epoch", epoch, 0)

    def _ranks(self) -> Tuple[int, int]:
        if self.world_size is not None:
            return self.rank, self.world_size
        dist = torch.distributed
        if dist.is_available() and dist.is_initialized():
            return dist.get_rank(), dist.get_world_size()
        return 0, 1

    def _blocks(self) -> Optional[int]:
        if self.samples is None:
            return None
        return -(-self.samples // self.block)

    def __len__(self) -> int:
        """The samples this rank draws (only for a finite ``samples``)."""
        blocks = self._blocks()
        if blocks is None:
            raise TypeError("an unlimited ClutterDataset (samples=None) has no length")
        rank, world = self._ranks()
        total = 0
        for b in range(rank, blocks, world):
            total += min(self.block, self.samples - b * self.block)
        return total

    def __iter__(self) -> Iterator[object]:
        rank, world = self._ranks()
        info = get_worker_info()
        worker, workers = (info.id, info.num_workers) if info is not None else (0, 1)
        threads = self.threads if self.threads is not None else (1 if info is not None else None)
        seed = epoch_seed(self.seed, self.epoch)
        blocks = self._blocks()
        j = worker  # the rank's j-th block is block j * world + rank of the stream
        while True:
            b = j * world + rank
            if blocks is not None and b >= blocks:
                return
            start = b * self.block
            n = self.block if self.samples is None else min(self.block, self.samples - start)
            x = torch.from_numpy(self.model.generate(n, seed, start=start, threads=threads))
            for s in x:
                yield s if self.transform is None else self.transform(s)
            j += workers

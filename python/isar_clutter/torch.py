"""Unlimited clutter for PyTorch: ``ClutterDataset``, an ``IterableDataset`` of generated samples.

Every sample is the one ``isar-clutter generate --seed`` writes at its index (``block`` only
says how many are generated at once). The stream is dealt out in batches of ``batch_size``
(default: ``block``): at step ``s`` distributed rank ``r`` of ``R`` takes the ``r``-th batch of
the step's ``R`` batches, so the ranks' step ``s`` together hold the stream's samples
``s * R * batch_size ..`` in order, and within a rank DataLoader worker ``k`` of ``W`` makes the
rank's batches ``k, k + W, ...``, which a DataLoader hands out in order for any ``num_workers``.
A single process (one rank) thus sees the samples ``0, 1, 2, ...``.

Finite streams (``samples=N``) follow ``DistributedSampler``'s rule so that DistributedDataParallel
never waits on a rank: every rank draws the same number of samples, ``ceil(N / R)`` with
``remainder="pad"`` (the default; the ``R * ceil(N / R) - N < R`` missing samples wrap around to
the stream's first samples, so every sample is seen and at most ``R - 1`` twice) or
``floor(N / R)`` with ``remainder="drop"`` (the last ``N mod R`` samples are not drawn). Every
rank then has the same number of full batches and, when ``batch_size`` does not divide its
share, the same short last batch (its step's samples shared evenly): the ranks' batch sizes
are one sequence. ``samples_per_rank=K`` gives an unlimited stream epochs of ``K`` samples per
rank (the first ``R * K`` of the epoch's stream). ``set_epoch(e)`` draws epoch ``e`` from
``epoch_seed(seed, e)``: fresh samples, the same on every run (call it on the dataset a
DataLoader pickles into its workers at each epoch: ``persistent_workers=False``, the default).

    from isar_clutter.torch import ClutterDataset
    data = ClutterDataset("models/m2", seed=1, samples=10_000, batch_size=64)
    for epoch in range(30):
        data.set_epoch(epoch)
        for batch in data.loader(num_workers=2):   # DataLoader(data, batch_size=64, ...)
            ...  # complex64 tensors [64, H, W]; the same number of steps on every rank
"""

from __future__ import annotations

import os
from typing import Callable, Iterator, List, Optional, Tuple, Union

import torch
from torch.utils.data import DataLoader, IterableDataset, get_worker_info

from . import Model, epoch_seed

__all__ = ["ClutterDataset", "REMAINDERS"]

REMAINDERS = ("pad", "drop")
"""The rules for a finite stream that does not divide evenly between the ranks."""


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
        samples: how many distinct samples an epoch holds over every rank; ``None``: unlimited.
        transform: applied to every sample (a complex64 tensor ``[H, W]``) before it is yielded.
        block: the most samples generated at once (memory and speed, never which samples).
        rank, world_size: this process's share in distributed training (default: from
            ``torch.distributed`` when it is initialised, else one process).
        threads: generation threads (default: 1 in a DataLoader worker, all cores otherwise).
        batch_size: the DataLoader's batch size, the unit dealt to ranks and workers
            (default: ``block``); ``loader()`` builds a DataLoader with it.
        remainder: ``"pad"`` or ``"drop"``: how a finite stream is made equal on every rank.
        samples_per_rank: an unlimited stream's epoch length on every rank.
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
        batch_size: Optional[int] = None,
        remainder: str = "pad",
        samples_per_rank: Optional[int] = None,
    ) -> None:
        super().__init__()
        if not isinstance(model, Model):
            model = Model.load(os.fspath(model))
        self.model = model
        self.seed = _count("seed", seed, 0)
        self.samples = _count("samples", samples, 0)
        self.samples_per_rank = _count("samples_per_rank", samples_per_rank, 1)
        if self.samples is not None and self.samples_per_rank is not None:
            raise ValueError("samples and samples_per_rank do not go together (samples_per_rank is "
                             "an unlimited stream's epoch)")
        self.transform = transform
        self.block = _count("block", block, 1)
        self.batch_size = _count("batch_size", batch_size, 1) or self.block
        if remainder not in REMAINDERS:
            raise ValueError(f"remainder must be one of {', '.join(REMAINDERS)}, not {remainder!r}")
        self.remainder = remainder
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

    def loader(self, **kwargs) -> DataLoader:
        """A DataLoader over this dataset with its ``batch_size``; other arguments pass through.

        A different ``batch_size`` is refused: batches would then be cut across the ranks' shares.
        """
        batch = kwargs.pop("batch_size", self.batch_size)
        if batch != self.batch_size:
            raise ValueError(f"the DataLoader's batch_size {batch} is not the dataset's batch_size "
                             f"{self.batch_size}: give ClutterDataset(batch_size={batch})")
        return DataLoader(self, batch_size=batch, **kwargs)

    def _ranks(self) -> Tuple[int, int]:
        if self.world_size is not None:
            return self.rank, self.world_size
        dist = torch.distributed
        if dist.is_available() and dist.is_initialized():
            return dist.get_rank(), dist.get_world_size()
        return 0, 1

    def _epoch(self, world: int) -> Tuple[Optional[int], Optional[int]]:
        """(the stream's distinct samples, this rank's share), None for unlimited."""
        if self.samples_per_rank is not None:
            return world * self.samples_per_rank, self.samples_per_rank
        if self.samples is None:
            return None, None
        share = -(-self.samples // world) if self.remainder == "pad" else self.samples // world
        return self.samples, share

    def __len__(self) -> int:
        """The samples this rank draws in an epoch (only for a finite or epoch-limited stream)."""
        _, share = self._epoch(self._ranks()[1])
        if share is None:
            raise TypeError("an unlimited ClutterDataset (samples=None) has no length: give "
                            "samples or samples_per_rank")
        return share

    def _batch(self, j: int, rank: int, world: int, distinct: Optional[int],
               share: Optional[int]) -> List[Tuple[int, int]]:
        """The stream's (start, count) ranges of the rank's ``j``-th batch; [] past its share."""
        b = self.batch_size
        if share is not None and j * b >= share:
            return []
        size = b if share is None else min(b, share - j * b)
        start = j * world * b + rank * size
        if distinct is None or start + size <= distinct:
            return [(start, size)]
        ranges, left = [], size  # pad: the indices past the end wrap to the stream's start
        while left:
            at = start % distinct
            n = min(left, distinct - at)
            ranges.append((at, n))
            start, left = start + n, left - n
        return ranges

    def __iter__(self) -> Iterator[object]:
        rank, world = self._ranks()
        info = get_worker_info()
        worker, workers = (info.id, info.num_workers) if info is not None else (0, 1)
        threads = self.threads if self.threads is not None else (1 if info is not None else None)
        seed = epoch_seed(self.seed, self.epoch)
        distinct, share = self._epoch(world)
        j = worker
        while True:
            ranges = self._batch(j, rank, world, distinct, share)
            if not ranges:
                return
            for start, count in ranges:
                for at in range(start, start + count, self.block):
                    n = min(self.block, start + count - at)
                    x = torch.from_numpy(self.model.generate(n, seed, start=at, threads=threads))
                    for s in x:
                        yield s if self.transform is None else self.transform(s)
            j += workers

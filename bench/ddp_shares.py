#!/usr/bin/env python3
"""What every distributed rank of a finite ``ClutterDataset`` draws (issue 51's table).

For world sizes 1-4, DataLoader workers 0-3 and 1000, 1001 and 1100 samples (batch 64), each
rank's DataLoader is iterated as that rank would under DistributedDataParallel (``rank`` and
``world_size`` given explicitly, so no process group is needed) and the samples and batches it
yields are counted, the short batches among them too. A row is ``equal`` when every rank took
the same number of samples and of batches and the batch sizes are the same sequence on every
rank (the condition for DDP's all-reduces to pair up). It also checks that no sample is drawn
twice in an epoch beyond what the remainder rule pads. Prints a Markdown table.

    python bench/ddp_shares.py [--remainder pad|drop] [--batch 64] [--block 64]
"""

import argparse
import sys

import numpy as np
from torch.utils.data import DataLoader

import isar_clutter as ic
from isar_clutter.torch import ClutterDataset


def shares(model, samples, world, workers, batch, block, remainder):
    """Per rank: (sample count, batch sizes in order, the samples' first values)."""
    out = []
    for rank in range(world):
        kw = {"rank": rank, "world_size": world, "block": block}
        if remainder is not None:
            kw.update(remainder=remainder, batch_size=batch)
        data = ClutterDataset(model, seed=3, samples=samples, **kw)
        sizes, firsts = [], []
        for b in DataLoader(data, batch_size=batch, num_workers=workers):
            sizes.append(len(b))
            firsts.extend(b[:, 0, 0].numpy().tolist())
        out.append((sum(sizes), sizes, firsts))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--remainder", choices=["pad", "drop"], default=None,
                    help="the remainder rule (default: the dataset's default; omit for old versions)")
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--block", type=int, default=64)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 1001, 1100])
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    stack = (rng.standard_normal((50, 8, 8)) + 1j * rng.standard_normal((50, 8, 8))).astype(np.complex64)
    model = ic.fit(stack, method="method1")
    print(f"batch {args.batch}, block {args.block}, remainder {args.remainder or 'default'}\n")
    print("| samples | world | workers | samples per rank | batches per rank (short) | equal | distinct samples |")
    print("|---|---|---|---|---|---|---|")
    unequal = 0
    for samples in args.sizes:
        for world in range(1, 5):
            for workers in range(4):
                got = shares(model, samples, world, workers, args.batch, args.block, args.remainder)
                counts = [c for c, _, _ in got]
                batches = [f"{len(s)} ({sum(1 for x in s if x < args.batch)})" for _, s, _ in got]
                equal = len({tuple(s) for _, s, _ in got}) == 1
                unequal += not equal
                distinct = len({v for _, _, f in got for v in f})
                print(f"| {samples} | {world} | {workers} | {', '.join(map(str, counts))} | "
                      f"{', '.join(batches)} | {'yes' if equal else '**no**'} | {distinct} of {sum(counts)} |")
    print(f"\n{unequal} of {len(args.sizes) * 16} configurations give ranks unequal batches")
    return 1 if unequal else 0


if __name__ == "__main__":
    sys.exit(main())

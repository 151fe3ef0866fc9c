#!/usr/bin/env python3
"""Trains a small network with DistributedDataParallel on clutter streamed by every rank.

Each rank streams its share of one finite `ClutterDataset` (the same number of samples and of
batches on every rank, see `isar_clutter.torch`), so every step's all-reduce has a partner on
every rank and the run ends together, whatever `--samples`, the world size or `--workers`.
The network learns each sample's mean magnitude from its magnitude image (a task with a
target in every sample, so that any model folder can be used).

    isar-clutter fit --input clutter.npy --method method2 --out models/m2
    torchrun --standalone --nproc-per-node 3 examples/ddp_train.py --model models/m2 --samples 1001
    python examples/ddp_train.py --model models/m2     # one process, no process group

With `--record DIR` every rank writes `DIR/rank<r>.json`: its steps, its batch sizes and a
hash of every sample it saw (python/tests/test_ddp.py checks them against the rule).
"""

import argparse
import datetime
import hashlib
import json
import os
import time

import torch
import torch.distributed as dist
from torch import nn
from torch.nn.parallel import DistributedDataParallel

from isar_clutter.torch import REMAINDERS, ClutterDataset


def net() -> nn.Module:
    torch.manual_seed(0)  # the same initial weights on every rank
    return nn.Sequential(
        nn.Conv2d(1, 8, 3, padding=1), nn.ReLU(), nn.AdaptiveAvgPool2d(4),
        nn.Flatten(), nn.Linear(128, 1),
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", required=True, help="a model folder (isar-clutter fit --out)")
    ap.add_argument("--samples", type=int, default=1001, help="distinct samples an epoch holds over every rank")
    ap.add_argument("--batch-size", type=int, default=32)
    ap.add_argument("--epochs", type=int, default=2)
    ap.add_argument("--workers", type=int, default=1, help="DataLoader workers per rank")
    ap.add_argument("--remainder", choices=REMAINDERS, default="pad")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=60, help="seconds a collective may wait")
    ap.add_argument("--record", help="a folder for every rank's record")
    ap.add_argument("--stream-only", action="store_true", help="draw the batches, train nothing (the stream's rate)")
    args = ap.parse_args()
    torch.set_num_threads(1)
    distributed = "RANK" in os.environ  # started by torchrun
    if distributed:
        dist.init_process_group("gloo", timeout=datetime.timedelta(seconds=args.timeout))
    rank = dist.get_rank() if distributed else 0
    world = dist.get_world_size() if distributed else 1
    data = ClutterDataset(args.model, seed=args.seed, samples=args.samples, batch_size=args.batch_size,
                          remainder=args.remainder, threads=1)
    model = net()
    ddp = DistributedDataParallel(model) if distributed else model
    opt = torch.optim.SGD(ddp.parameters(), lr=0.01, momentum=0.9)
    steps, sizes, seen, loss = 0, [], [], torch.tensor(float("nan"))
    start = time.perf_counter()
    for epoch in range(args.epochs):
        data.set_epoch(epoch)
        for batch in data.loader(num_workers=args.workers):
            if args.record:
                seen.extend(hashlib.blake2b(s.numpy().tobytes(), digest_size=8).hexdigest() for s in batch)
            steps += 1
            sizes.append(len(batch))
            if args.stream_only:
                continue
            x = batch.abs()[:, None]
            target = x.mean(dim=(1, 2, 3))[:, None]
            loss = nn.functional.mse_loss(ddp(x), target)
            opt.zero_grad()
            loss.backward()
            opt.step()
    elapsed = time.perf_counter() - start
    total = torch.tensor([float(sum(sizes)), elapsed])
    if distributed:  # every rank is here after the same number of steps
        dist.all_reduce(total[:1])
        longest = torch.tensor([elapsed])
        dist.all_reduce(longest, op=dist.ReduceOp.MAX)
        total[1] = longest[0]
    print(f"rank {rank}/{world}: {steps} steps, {sum(sizes)} samples, loss {loss.item():.4f}, "
          f"{elapsed:.2f} s", flush=True)
    if rank == 0:
        print(f"all ranks: {int(total[0])} samples in {total[1]:.2f} s, {total[0] / total[1]:.0f} samples/s", flush=True)
    if args.record:
        with open(os.path.join(args.record, f"rank{rank}.json"), "w") as f:
            json.dump({"rank": rank, "world": world, "steps": steps, "sizes": sizes, "seen": seen,
                       "seconds": elapsed, "len": len(data)}, f)
    if distributed:
        dist.destroy_process_group()


if __name__ == "__main__":
    main()

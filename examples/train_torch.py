#!/usr/bin/env python3
"""Trains a small PyTorch network on clutter streamed from two synthesis models.

Two models are fitted to two kinds of clutter (weakly and strongly correlated along rows);
`ClutterDataset` streams fresh samples of each into a DataLoader, and a small CNN learns to
tell them apart from the magnitude images. Every batch is new clutter: the network never sees
a sample twice.

    pip install ./python torch     # or: make python
    python examples/train_torch.py [--steps 60]
"""

import argparse

import numpy as np
import torch
from torch import nn
from torch.utils.data import DataLoader

import isar_clutter as ic
from isar_clutter.torch import ClutterDataset


def clutter(rho: float, seed: int) -> np.ndarray:
    """200 samples of 32 x 32 complex clutter correlated `rho` along rows."""
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((200, 32, 32)) + 1j * rng.standard_normal((200, 32, 32))
    return (z + rho * np.roll(z, 1, axis=2)).astype(np.complex64)


class Labelled(torch.utils.data.IterableDataset):
    """Samples of two streams in turn, labelled 0 and 1, as magnitude images [1, H, W]."""

    def __init__(self, a: ClutterDataset, b: ClutterDataset):
        self.a, self.b = a, b

    def __iter__(self):
        for x, y in zip(self.a, self.b):
            yield x.abs()[None], 0
            yield y.abs()[None], 1


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=60)
    args = ap.parse_args()
    weak = ic.fit(clutter(0.1, 1), method="method2", levels=2, half_width=4)
    strong = ic.fit(clutter(0.9, 2), method="method2", levels=2, half_width=4)
    data = Labelled(ClutterDataset(weak, seed=10), ClutterDataset(strong, seed=20))
    net = nn.Sequential(
        nn.Conv2d(1, 8, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
        nn.Conv2d(8, 8, 3, padding=1), nn.ReLU(), nn.AdaptiveAvgPool2d(1),
        nn.Flatten(), nn.Linear(8, 2),
    )
    opt = torch.optim.Adam(net.parameters(), lr=1e-2)
    for step, (x, y) in enumerate(DataLoader(data, batch_size=64)):
        loss = nn.functional.cross_entropy(net(x), y)
        opt.zero_grad()
        loss.backward()
        opt.step()
        if step % 10 == 0 or step == args.steps - 1:
            acc = (net(x).argmax(1) == y).float().mean().item()
            print(f"step {step:3d}  loss {loss.item():.3f}  batch accuracy {acc:.2f}")
        if step + 1 == args.steps:
            break


if __name__ == "__main__":
    main()

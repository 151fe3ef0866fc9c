"""From SICD images to a DataLoader of generated clutter: read the same window of a stack of
coregistered SICD images (one sample each, a collection over time or aspect), fit a synthesis
model to it, and stream fresh samples with its statistics into PyTorch.

    python examples/sicd_to_dataloader.py --window 2000 3000 64 64 --out models/forest \\
        umbra_20240501.nitf umbra_20240508.nitf umbra_20240515.nitf ...

Any number of images (at least 2; a few dozen make a better fit); the window (row, column,
rows, columns) must hold clutter only. Prints what it read and the first batch's shape.
"""

import argparse

import numpy as np

import isar_clutter as ic
from isar_clutter.torch import ClutterDataset


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("images", nargs="+", help="SICD files (.nitf), coregistered")
    p.add_argument("--window", nargs=4, type=int, metavar=("ROW", "COL", "ROWS", "COLS"),
                   required=True, help="the clutter window read from every image")
    p.add_argument("--method", default="method2", help="synthesis method (default method2)")
    p.add_argument("--out", help="save the fitted model to this folder")
    p.add_argument("--batch-size", type=int, default=32)
    a = p.parse_args()

    stack = ic.load(a.images, window=tuple(a.window))  # complex64 [N, ROWS, COLS]
    print(f"read {stack.shape[0]} windows of {stack.shape[1]} x {stack.shape[2]}, "
          f"mean power {np.mean(np.abs(stack) ** 2):.4g}")
    levels = max(1, min(3, int(np.log2(min(stack.shape[1:]))) - 2))
    model = ic.fit(stack, method=a.method, levels=levels, source=", ".join(a.images))
    if a.out:
        model.save(a.out)
    data = ClutterDataset(model, seed=1, samples=10 * a.batch_size, batch_size=a.batch_size)
    batch = next(iter(data.loader()))
    print(f"first batch: {tuple(batch.shape)} {batch.dtype}")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""PyTorch reference benchmark for the CNNs of Tables 18 and 23 (for BENCHMARKS.md).

Measures CPU training throughput -- samples per second of forward + backward + an
SGD-with-momentum update -- and prediction throughput (forward only, eval mode, under
torch.inference_mode) of the two small networks that isar-clutter trains with burn,
so the Rust numbers can be put side by side with a mainstream framework on the same machine.

The networks (input 2 x 64 x 64 float32, NCHW; MATLAB 'same' padding):
  conv 8x8/2 'same' F1 -> BN -> ReLU -> maxpool 2/2
  -> conv 4x4/2 'same' F2 -> BN -> ReLU -> maxpool 2/2
  -> conv 2x2/2 'same' F3 -> BN -> ReLU -> flatten -> Linear -> cross-entropy
  table18 (classification): F = 16, 64, 128; flatten 512 -> Linear(512, 4)
  table23 (location):       F = 64, 16, 16;  flatten 64  -> Linear(64, 25)
Glorot-uniform weights, zero biases; SGD(lr=0.01, momentum=0.9, weight_decay=1e-4).

Random inputs and labels are drawn once from a fixed seed before timing; only the timed
steps (after the warm-up steps) are inside time.perf_counter.

Run (torch lives in its own virtualenv, .venv-torch, made by `make bench-torch-deps`):
    make bench-cnn-torch                       # both nets, 1 and 2 threads
    .venv-torch/bin/python bench/cnn_torch.py --net table18 --threads 2 --batches 50 --json
    python3 bench/cnn_torch.py --device cuda   # on a machine with an NVIDIA GPU (batches resident there)

OMP_WAIT_POLICY: unless already set, this script sets OMP_WAIT_POLICY=PASSIVE before
importing torch. With the default (active) policy, idle OpenMP workers spin between
parallel regions; on a small (2-core) machine they then steal the CPU from the main
thread and from other processes and make the timings slower and noisier. Set it yourself
(e.g. OMP_WAIT_POLICY=ACTIVE) to override.
"""
import argparse
import json
import math
import os
import sys
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import torch  # noqa: E402  (must come after OMP_WAIT_POLICY is set)
from torch import nn  # noqa: E402

NETS = {
    # name: (filters of the three conv layers, number of classes)
    "table18": ((16, 64, 128), 4),
    "table23": ((64, 16, 16), 25),
}
KERNELS = (8, 4, 2)
STRIDE = 2
INPUT_SHAPE = (2, 64, 64)


def same_padding(size, kernel, stride):
    """MATLAB 'same': out = ceil(in/stride); the smaller half of the padding goes first."""
    out = math.ceil(size / stride)
    total = max((out - 1) * stride + kernel - size, 0)
    before = total // 2
    return before, total - before, out


class SameConv2d(nn.Sequential):
    """Conv2d with MATLAB 'same' padding (symmetric padding inside the conv when possible)."""

    def __init__(self, in_ch, out_ch, kernel, stride, in_size):
        top, bottom, out = same_padding(in_size, kernel, stride)
        layers = []
        if top == bottom:
            conv = nn.Conv2d(in_ch, out_ch, kernel, stride=stride, padding=top)
        else:
            layers.append(nn.ZeroPad2d((top, bottom, top, bottom)))  # left, right, top, bottom
            conv = nn.Conv2d(in_ch, out_ch, kernel, stride=stride, padding=0)
        layers.append(conv)
        super().__init__(*layers)
        self.out_size = out


def build_net(filters, classes):
    channels, size = INPUT_SHAPE[0], INPUT_SHAPE[1]
    layers = []
    for i, (f, k) in enumerate(zip(filters, KERNELS)):
        conv = SameConv2d(channels, f, k, STRIDE, size)
        size = conv.out_size
        layers += [conv, nn.BatchNorm2d(f), nn.ReLU(inplace=True)]
        if i < 2:
            layers.append(nn.MaxPool2d(2, stride=2))
            size //= 2
        channels = f
    layers += [nn.Flatten(), nn.Linear(channels * size * size, classes)]
    net = nn.Sequential(*layers)
    for m in net.modules():
        if isinstance(m, (nn.Conv2d, nn.Linear)):
            nn.init.xavier_uniform_(m.weight)
            nn.init.zeros_(m.bias)
    return net


def bench(name, batch_size, warmup, steps, seed, device="cpu"):
    filters, classes = NETS[name]
    torch.manual_seed(seed)
    net = build_net(filters, classes).to(device).train()
    opt = torch.optim.SGD(net.parameters(), lr=0.01, momentum=0.9, weight_decay=1e-4, dampening=0)
    loss_fn = nn.CrossEntropyLoss()

    gen = torch.Generator().manual_seed(seed)
    n_distinct = min(warmup + steps, 8)  # a few distinct batches, cycled
    xs = [torch.randn(batch_size, *INPUT_SHAPE, generator=gen).to(device) for _ in range(n_distinct)]
    ys = [torch.randint(0, classes, (batch_size,), generator=gen).to(device) for _ in range(n_distinct)]

    def sync():
        # GPU work is asynchronous: wait for it before reading a clock.
        if device != "cpu":
            torch.cuda.synchronize()

    def step(i):
        x, y = xs[i % n_distinct], ys[i % n_distinct]
        opt.zero_grad(set_to_none=True)
        loss = loss_fn(net(x), y)
        loss.backward()
        opt.step()
        return loss

    for i in range(warmup):
        step(i)
    sync()
    t0 = time.perf_counter()
    for i in range(warmup, warmup + steps):
        loss = step(i)
    sync()
    elapsed = time.perf_counter() - t0
    if not torch.isfinite(loss):
        raise RuntimeError(f"{name}: non-finite loss {loss.item()}")
    # Prediction: forward only, inference mode (BN running statistics), no autodiff graph.
    net.eval()
    with torch.inference_mode():
        for i in range(warmup):
            net(xs[i % n_distinct])
        sync()
        t1 = time.perf_counter()
        for i in range(steps):
            net(xs[i % n_distinct])
        sync()
        predict = batch_size * steps / (time.perf_counter() - t1)
    return batch_size * steps / elapsed, elapsed, predict


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    p.add_argument("--net", choices=["table18", "table23", "both"], default="both")
    p.add_argument("--threads", type=int, default=1, help="torch.set_num_threads (default 1)")
    p.add_argument("--batches", type=int, default=30, help="timed steps (default 30)")
    p.add_argument("--warmup", type=int, default=5, help="untimed warm-up steps (default 5)")
    p.add_argument("--batch-size", type=int, default=128)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="one JSON object per net on stdout")
    p.add_argument("--device", choices=["cpu", "cuda"], default="cpu",
                   help="cuda: the GPU, the batches resident there (default cpu)")
    p.add_argument("--no-tf32", action="store_true",
                   help="cuda: float convolutions (torch.backends.cudnn.allow_tf32 = False; "
                        "PyTorch's default lets cuDNN use TF32 tensor cores)")
    a = p.parse_args()
    if a.threads < 1 or a.batches < 1 or a.batch_size < 1 or a.warmup < 0:
        p.error("--threads, --batches and --batch-size must be >= 1, --warmup >= 0")

    torch.set_num_threads(a.threads)
    if a.no_tf32:
        torch.backends.cudnn.allow_tf32 = False
    nets = ["table18", "table23"] if a.net == "both" else [a.net]
    for name in nets:
        sps, elapsed, predict = bench(name, a.batch_size, a.warmup, a.batches, a.seed, a.device)
        if a.json:
            print(json.dumps({
                "net": name,
                "threads": a.threads,
                "device": a.device,
                "batch_size": a.batch_size,
                "samples_per_second": round(sps, 2),
                "predict_samples_per_second": round(predict, 2),
                "steps": a.batches,
                "torch_version": torch.__version__,
                "cudnn_tf32": bool(torch.backends.cudnn.allow_tf32),
            }), flush=True)
        else:
            print(f"{name}: {sps:9.1f} samples/s  ({a.batches} steps of {a.batch_size} in "
                  f"{elapsed:.2f} s, {1000 * elapsed / a.batches:.1f} ms/step; "
                  f"predicted {predict:.1f} samples/s; "
                  f"threads={a.threads}, device={a.device}, torch {torch.__version__}, "
                  f"OMP_WAIT_POLICY={os.environ['OMP_WAIT_POLICY']})", flush=True)


if __name__ == "__main__":
    sys.exit(main())

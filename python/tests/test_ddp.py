"""DistributedDataParallel on a streamed ClutterDataset under a real process group: three ranks
started by torchrun (gloo, CPU) train examples/ddp_train.py on a finite stream that does not
divide evenly (1001 samples, batch 32, two epochs) within a timeout; every rank takes the same
steps with the same batch sizes, and the samples seen are the remainder rule's.

With the sharing before issue 51 (blocks dealt in turn) the ranks took 11, 11 and 10 steps here
and the run failed: a rank's extra all-reduce met another rank's next collective (gloo:
"collective mismatch") or waits for a partner that never comes."""

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter

import numpy as np
import pytest

import isar_clutter as ic

from conftest import ROOT, clutter

WORLD, SAMPLES, BATCH, EPOCHS, TIMEOUT = 3, 1001, 32, 2, 240


def digests(x: np.ndarray) -> list:
    return [hashlib.blake2b(s.tobytes(), digest_size=8).hexdigest() for s in x]


def torchrun(model_dir, record, remainder):
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", f"--nproc-per-node={WORLD}",
           str(ROOT / "examples" / "ddp_train.py"), "--model", str(model_dir), "--samples", str(SAMPLES),
           "--batch-size", str(BATCH), "--epochs", str(EPOCHS), "--workers", "1",
           "--remainder", remainder, "--timeout", "60", "--record", str(record)]
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # torchrun, its ranks and their DataLoader workers
        out, _ = proc.communicate()
        pytest.fail(f"DDP did not finish within {TIMEOUT} s (a rank waits on a collective):\n{out[-3000:]}")
    assert proc.returncode == 0, f"torchrun failed ({proc.returncode}):\n{out[-3000:]}"
    return out, time.perf_counter() - start


@pytest.mark.parametrize("remainder", ["pad", "drop"])
def test_ddp_ranks_take_equal_steps_and_see_the_rule_s_samples(tmp_path, remainder):
    model = ic.fit(clutter(n=50, h=8, w=8, seed=4), method="method1")
    model.save(tmp_path / "m")
    out, seconds = torchrun(tmp_path / "m", tmp_path, remainder)
    records = [json.loads((tmp_path / f"rank{r}.json").read_text()) for r in range(WORLD)]
    share = -(-SAMPLES // WORLD) if remainder == "pad" else SAMPLES // WORLD
    steps = EPOCHS * -(-share // BATCH)
    print(f"\n{remainder}: steps per rank {[r['steps'] for r in records]}, {seconds:.1f} s with torchrun\n{out}")
    for r in records:
        assert r["world"] == WORLD and r["len"] == share
        assert r["steps"] == steps and r["sizes"] == records[0]["sizes"]
        assert sum(r["sizes"]) == EPOCHS * share
    for epoch in range(EPOCHS):
        stream = digests(model.generate(SAMPLES, ic.epoch_seed(1, epoch)))
        seen = Counter(h for r in records for h in r["seen"][epoch * share:(epoch + 1) * share])
        if remainder == "pad":  # every sample once, the first WORLD * share - SAMPLES twice
            twice = WORLD * share - SAMPLES
            assert seen == Counter(stream + stream[:twice])
        else:  # the first WORLD * share samples once, the rest not drawn
            assert seen == Counter(stream[:WORLD * share])

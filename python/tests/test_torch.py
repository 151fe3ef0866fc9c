"""ClutterDataset in a real torch DataLoader: the documented samples for 0, 1 and 2 workers,
every rank the same batches whose union is the remainder rule's, fresh epochs."""

import numpy as np
import pytest

import torch  # noqa: E402  (the tests need torch: `make test` installs it)
from torch.utils.data import DataLoader  # noqa: E402

import isar_clutter as ic  # noqa: E402
from isar_clutter.torch import ClutterDataset  # noqa: E402

from conftest import clutter  # noqa: E402

BLOCK = 8


@pytest.fixture(scope="module")
def model():
    return ic.fit(clutter(n=50, h=8, w=8, seed=2), method="method1")


def drawn(loader):
    return np.concatenate([b.numpy() for b in loader])


@pytest.mark.parametrize("workers", [0, 1, 2])
def test_the_loader_gives_the_stream_in_order_for_any_worker_count(model, workers):
    data = ClutterDataset(model, seed=11, samples=45, block=BLOCK)
    loader = DataLoader(data, batch_size=BLOCK, num_workers=workers)
    got = drawn(loader)
    assert got.shape == (45, 8, 8) and got.dtype == np.complex64
    assert got.tobytes() == model.generate(45, 11).tobytes()
    assert len(data) == 45


def ranks(model, world, workers, **kw):
    """Every rank's samples and batch sizes, each rank's DataLoader iterated as DDP would."""
    got = []
    for rank in range(world):
        data = ClutterDataset(model, rank=rank, world_size=world, **kw)
        batches = [b.numpy() for b in data.loader(num_workers=workers)]
        samples = np.concatenate(batches) if batches else np.zeros((0, 8, 8), np.complex64)
        assert len(samples) == len(data)
        got.append((samples, [len(b) for b in batches]))
    return got


@pytest.mark.parametrize("remainder", ["pad", "drop"])
@pytest.mark.parametrize("world,workers", [(1, 0), (2, 2), (3, 0), (3, 2), (4, 1)])
def test_every_rank_takes_the_same_batches_and_the_union_is_the_rule_s(model, remainder, world, workers):
    for samples in (45, 46, 47, 2):
        got = ranks(model, world, workers, seed=5, samples=samples, batch_size=BLOCK, block=3,
                    remainder=remainder)
        share = -(-samples // world) if remainder == "pad" else samples // world
        assert all(sizes == got[0][1] for _, sizes in got), (samples, [s for _, s in got])
        assert all(len(x) == share for x, _ in got)
        assert all(size == BLOCK for size in got[0][1][:-1])
        # Step s of every rank together is the stream's next world * (batch size) samples, in rank
        # order; past the end the stream wraps to its start (pad) or stops (drop).
        steps = [np.concatenate([x[sum(got[0][1][:k]):sum(got[0][1][:k + 1])] for x, _ in got])
                 for k in range(len(got[0][1]))]
        union = np.concatenate(steps) if steps else np.zeros((0, 8, 8), np.complex64)
        stream = model.generate(samples, 5)
        expect = np.concatenate([stream] * 3)[:world * share]
        assert union.tobytes() == expect.tobytes()


def test_the_batch_size_is_not_the_block_size_and_a_loader_with_another_batch_is_refused(model):
    alone = ranks(model, 3, 2, seed=7, samples=50, batch_size=8, block=8)
    for block in (3, 5, 64):  # the samples never depend on the block
        again = ranks(model, 3, 2, seed=7, samples=50, batch_size=8, block=block)
        assert all(a.tobytes() == b.tobytes() and sa == sb for (a, sa), (b, sb) in zip(alone, again))
    data = ClutterDataset(model, seed=7, samples=50, batch_size=8, block=5)
    with pytest.raises(ValueError, match="batch_size 16 is not the dataset's batch_size 8"):
        data.loader(batch_size=16)


def test_an_unlimited_stream_with_an_epoch_per_rank(model):
    got = ranks(model, 3, 1, seed=9, samples_per_rank=20, batch_size=BLOCK)
    assert [sizes for _, sizes in got] == [[8, 8, 4]] * 3
    steps = [np.concatenate([x[k * 8:(k + 1) * 8] for x, _ in got]) for k in range(3)]
    assert np.concatenate(steps).tobytes() == model.generate(60, 9).tobytes()
    data = ClutterDataset(model, seed=9, samples_per_rank=20, rank=1, world_size=3)
    data.set_epoch(2)
    assert len(data) == 20 and len(drawn(data.loader())) == 20


def test_an_unlimited_stream_and_fresh_epochs(model):
    data = ClutterDataset(model, seed=3, block=4, transform=lambda s: s.abs())
    it = iter(DataLoader(data, batch_size=4))
    first = [next(it) for _ in range(5)]
    assert all(b.shape == (4, 8, 8) and b.dtype == torch.float32 for b in first)
    assert np.allclose(torch.cat(first).numpy(), np.abs(model.generate(20, 3)))
    data = ClutterDataset(model, seed=3, samples=8, block=4)
    data.set_epoch(1)
    got = drawn(DataLoader(data, batch_size=4))
    assert got.tobytes() == model.generate(8, ic.epoch_seed(3, 1)).tobytes()
    assert got.tobytes() != model.generate(8, 3).tobytes()
    assert ic.epoch_seed(3, 0) == 3


def test_a_model_folder_and_bad_arguments(model, tmp_path):
    model.save(tmp_path / "m")
    data = ClutterDataset(str(tmp_path / "m"), seed=1, samples=3, block=2)
    assert drawn(DataLoader(data, batch_size=2)).tobytes() == model.generate(3, 1).tobytes()
    with pytest.raises(ValueError, match="block"):
        ClutterDataset(model, seed=1, block=0)
    with pytest.raises(ValueError, match="rank"):
        ClutterDataset(model, seed=1, rank=2, world_size=2)
    with pytest.raises(TypeError, match="no length"):
        len(ClutterDataset(model, seed=1))
    with pytest.raises(ValueError, match="remainder must be one of pad, drop"):
        ClutterDataset(model, seed=1, samples=4, remainder="wrap")
    with pytest.raises(ValueError, match="samples and samples_per_rank"):
        ClutterDataset(model, seed=1, samples=4, samples_per_rank=2)
    with pytest.raises(ValueError, match="batch_size"):
        ClutterDataset(model, seed=1, batch_size=0)


def test_a_model_pickles_and_a_spawned_loader_gives_the_same_stream(model):
    import pickle

    again = pickle.loads(pickle.dumps(model))
    assert again.method == model.method and again.info_json == model.info_json
    assert again.generate(5, 9, start=3).tobytes() == model.generate(5, 9, start=3).tobytes()
    # Workers started with `spawn` receive the dataset pickled (model included).
    data = ClutterDataset(model, seed=11, samples=24, block=BLOCK)
    loader = DataLoader(data, batch_size=BLOCK, num_workers=2, multiprocessing_context="spawn")
    assert drawn(loader).tobytes() == model.generate(24, 11).tobytes()
    with pytest.raises(OSError, match="is not a file of a model folder"):
        ic.Model._from_files([("../escape.json", b"{}")])

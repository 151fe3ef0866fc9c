"""ClutterDataset in a real torch DataLoader: the documented samples for 0, 1 and 2 workers,
disjoint ranks whose union is the single-process stream, fresh epochs."""

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


def test_two_ranks_draw_disjoint_blocks_whose_union_is_the_stream(model):
    whole = model.generate(45, 5)
    parts = []
    for rank in (0, 1):
        data = ClutterDataset(model, seed=5, samples=45, block=BLOCK, rank=rank, world_size=2)
        got = drawn(DataLoader(data, batch_size=BLOCK, num_workers=2))
        assert len(got) == len(data)
        parts.append(got)
    # Rank r holds blocks r, r + 2, ...: interleaved they are the stream.
    blocks = [np.split(p, range(BLOCK, len(p), BLOCK)) for p in parts]
    merged = [b for pair in zip(*blocks) for b in pair] + blocks[0][len(blocks[1]):]
    assert np.concatenate(merged).tobytes() == whole.tobytes()
    assert len(parts[0]) + len(parts[1]) == 45


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

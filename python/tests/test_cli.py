"""The package against the command line: the same samples byte for byte, the same models,
the same maps as a run's `maps/`."""

import numpy as np
import pytest

import isar_clutter as ic
from conftest import clutter

SEEDS = [0, 7, 2**63 + 5]


@pytest.mark.parametrize("method", ["method1", "method2"])
def test_generate_is_byte_for_byte_the_command_lines(tmp_path, cli, stack, method):
    np.save(tmp_path / "stack.npy", stack)
    folder = tmp_path / f"{method}.model"
    cli("fit", "--input", tmp_path / "stack.npy", "--method", method, "--out", folder)
    model = ic.Model.load(folder)
    assert model.method == method and model.shape == (16, 16)
    for seed in SEEDS:
        out = tmp_path / f"{method}.{seed}.npy"
        cli("generate", "--model", folder, "--samples", 20, "--seed", seed, "--out", out)
        theirs = np.load(out)
        ours = model.generate(20, seed)
        assert ours.dtype == np.complex64 and ours.shape == (20, 16, 16)
        assert ours.tobytes() == theirs.tobytes()
        # Sample i is the same drawn alone, in blocks, or on one thread.
        assert model.generate(5, seed, start=7).tobytes() == theirs[7:12].tobytes()
        assert model.generate(1, seed, start=19, threads=1).tobytes() == theirs[19:].tobytes()


@pytest.mark.parametrize("method", ["method1", "method2", "full_covariance"])
def test_fit_here_is_the_command_lines_fit_and_folders_go_both_ways(tmp_path, cli, stack, method):
    np.save(tmp_path / "stack.npy", stack)
    theirs = tmp_path / "cli.model"
    cli("fit", "--input", tmp_path / "stack.npy", "--method", method, "--out", theirs)
    ours = ic.fit(stack, method=method)
    ours.save(tmp_path / "py.model")
    # The command line generates from the folder Python saved, Python from the command line's.
    out = tmp_path / "from_py.npy"
    cli("generate", "--model", tmp_path / "py.model", "--samples", 6, "--seed", 3, "--out", out)
    assert np.load(out).tobytes() == ours.generate(6, 3).tobytes()
    assert ic.Model.load(theirs).generate(6, 3).tobytes() == ours.generate(6, 3).tobytes()


def test_analyse_gives_the_maps_of_a_run(tmp_path, cli):
    stack = clutter(n=40, h=16, w=16, seed=4, dtype=np.complex128)
    np.save(tmp_path / "stack.npy", stack)
    spec = tmp_path / "s.yaml"
    spec.write_text(
        "name: maps\nseed: 1\ndatasets:\n  - id: d\n    kind: npy\n    path: stack.npy\n"
        "analysis:\n  levels: 2\noutputs:\n  npy_maps: true\n"
    )
    cli("run", spec, "--out", tmp_path / "out", "-q", "--no-report")
    jobs = list((tmp_path / "out" / "maps").iterdir())
    assert len(jobs) == 1
    maps = ic.analyse(stack, levels=2)
    files = sorted(p.stem for p in jobs[0].glob("*.npy"))
    assert files == sorted(k for k in maps if k != "samples")
    for name in files:
        theirs = np.load(jobs[0] / f"{name}.npy")
        assert theirs.dtype == maps[name].dtype, name
        np.testing.assert_array_equal(maps[name], theirs, err_msg=name)
    assert maps["samples"] == 40

"""Fixtures of the package's tests: the command line's binary (the tests compare with it, so
they fail, not skip, when it is missing) and small stacks."""

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _binary() -> Path:
    if os.environ.get("ISAR_CLUTTER_BIN"):
        return Path(os.environ["ISAR_CLUTTER_BIN"])
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "release" / "isar-clutter"


@pytest.fixture(scope="session")
def cli():
    """Runs the command line with the given arguments; fails on a non-zero exit."""
    binary = _binary()
    assert binary.is_file(), f"{binary} is missing: `make build` (or set ISAR_CLUTTER_BIN)"

    def run(*args):
        out = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)
        assert out.returncode == 0, f"isar-clutter {' '.join(map(str, args))}: {out.stderr}"
        return out

    return run


def clutter(n=60, h=16, w=16, seed=0, dtype=np.complex64):
    """A stack of correlated complex clutter: white noise smoothed along rows and columns."""
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((n, h, w)) + 1j * rng.standard_normal((n, h, w))
    z = z + 0.6 * np.roll(z, 1, axis=2) + 0.3 * np.roll(z, 1, axis=1)
    return z.astype(dtype)


@pytest.fixture
def stack():
    return clutter()

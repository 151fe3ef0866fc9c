"""Reads a .mat that `isar-clutter generate` wrote, as a MATLAB user's tools would, and checks
it against the .npy the same model and seed gave (tests/mat.rs runs it in .venv).

MAT v5 is read with SciPy's `loadmat`; v7.3 with h5py, checking MATLAB's conventions: the
512-byte user block opening with the v7.3 header (SciPy's `matfile_version` says 7.3), the
dataset's `MATLAB_class`, complex as a compound of `real` and `imag`, the dimensions reversed.
Either way the variable must be H x W x M of the class asked for, equal value for value to the
[M, H, W] complex64 .npy moved to H x W x M (single), or within single rounding of it (double).

Usage: python check_generated.py SAMPLES.npy OUT.mat VERSION(5|7.3) CLASS(single|double) VAR
Prints `ok H W M` and exits 0, or fails with the reason.
"""

import sys

import numpy as np
import scipy.io


def main():
    npy, mat, version, cls, var = sys.argv[1:6]
    expected = np.load(npy).transpose(1, 2, 0)  # [M, H, W] -> H x W x M
    dtype = {"single": np.complex64, "double": np.complex128}[cls]
    major, minor = scipy.io.matlab.matfile_version(mat)
    if version == "5":
        assert (major, minor) == (1, 0), f"SciPy sees MAT version {(major, minor)}, not 5"
        got = scipy.io.loadmat(mat)[var]
        names = [v[0] for v in scipy.io.whosmat(mat)]
        assert names == [var], f"variables {names}"
    else:
        import h5py

        assert (major, minor) == (2, 0), f"SciPy sees MAT version {(major, minor)}, not 7.3"
        with open(mat, "rb") as f:
            head = f.read(128)
        assert head.startswith(b"MATLAB 7.3 MAT-file"), head[:40]
        with h5py.File(mat, "r") as f:
            assert f.userblock_size == 512, f.userblock_size
            assert list(f.keys()) == [var], list(f.keys())
            d = f[var]
            assert d.attrs["MATLAB_class"] == cls.encode(), d.attrs["MATLAB_class"]
            part = {"single": "<f4", "double": "<f8"}[cls]
            assert d.dtype == np.dtype([("real", part), ("imag", part)]), d.dtype
            raw = d[()]
            got = (raw["real"] + 1j * raw["imag"]).astype(dtype).T  # HDF5 holds W x ... reversed
    assert got.shape == expected.shape, f"shape {got.shape}, expected {expected.shape}"
    assert got.dtype == dtype, f"dtype {got.dtype}, expected {dtype}"
    if cls == "single":
        assert np.array_equal(got, expected), "values differ from the .npy"
    else:
        # Sample format 2 computes in f32: double holds the .npy's values exactly, widened.
        assert np.array_equal(got, expected.astype(dtype)), "values differ from the .npy"
    print("ok", *got.shape)


if __name__ == "__main__":
    main()

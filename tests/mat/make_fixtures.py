"""MATLAB .mat fixtures for tests/mat.rs, written into the folder given on the command line.

The files are what MATLAB users meet: MAT v5 files written by SciPy's `scipy.io.savemat`
(complex64, complex128, float32, float64; compressed and not), a big-endian v5 file written
here byte by byte (SciPy writes native order only; read back by SciPy to prove it), files
holding every kind the reader must refuse (struct, cell, char, sparse, 2-D), and h5py files in
MATLAB's v7.3 conventions (512-byte user block with the MATLAB header text, dimensions
reversed, complex as a compound of `real` and `imag`, a `MATLAB_class` attribute; contiguous
and deflate-chunked), plus an HDF5 file that is not a MAT file. Every stack also goes to
`<name>.npy` with the same values, H x W x N in C order, for a value-for-value comparison.

Usage: python tests/mat/make_fixtures.py OUT_DIR   (needs numpy, scipy, h5py)
"""

import struct
import sys
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse

H, W, N = 4, 5, 3


def stack(dtype):
    """A deterministic H x W x N stack whose every value is distinct (and exact in float32)."""
    h, w, n = np.meshgrid(np.arange(H), np.arange(W), np.arange(N), indexing="ij")
    re = 100.0 * n + 10.0 * h + w + 0.25
    im = -(1000.0 * n + 10.0 * h + w + 0.5)
    a = re + 1j * im if np.issubdtype(np.dtype(dtype), np.complexfloating) else re
    return a.astype(dtype)


def be_v5(path, name, a):
    """A big-endian ('MI'), uncompressed MAT v5 file holding the numeric array `a`."""
    classes = {np.float64: (6, 9, ">f8"), np.float32: (7, 7, ">f4")}
    real = np.real(a)
    cls, mi, be = classes[real.dtype.type]

    def element(mi_type, payload):
        pad = (-len(payload)) % 8
        return struct.pack(">II", mi_type, len(payload)) + payload + b"\0" * pad

    flags = (0x0800 if np.iscomplexobj(a) else 0) | cls
    body = element(6, struct.pack(">II", flags, 0))  # miUINT32 array flags
    body += element(5, struct.pack(">" + "i" * a.ndim, *a.shape))  # miINT32 dimensions
    body += element(1, name.encode())  # miINT8 name
    body += element(mi, np.asfortranarray(real).astype(be).tobytes(order="F"))
    if np.iscomplexobj(a):
        body += element(mi, np.asfortranarray(np.imag(a)).astype(be).tobytes(order="F"))
    text = b"MATLAB 5.0 MAT-file, Platform: big-endian test, written by make_fixtures.py"
    header = text.ljust(116, b" ") + b"\0" * 8 + struct.pack(">H", 0x0100) + b"MI"
    with open(path, "wb") as f:
        f.write(header + struct.pack(">II", 14, len(body)) + body)


def v73(path, variables, chunked):
    """An HDF5 file in MATLAB v7.3 conventions holding `variables` (name -> numeric array)."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        for name, a in variables.items():
            cls = {np.float32: "single", np.float64: "double"}[np.real(a).dtype.type]
            data = a.T  # MATLAB is column-major: HDF5 holds the dimensions reversed
            if np.iscomplexobj(a):
                part = np.real(a).dtype
                compound = np.dtype([("real", part), ("imag", part)])
                c = np.empty(data.shape, dtype=compound)
                c["real"], c["imag"] = data.real, data.imag
                data = c
            opts = {"chunks": True, "compression": "gzip"} if chunked else {}
            d = f.create_dataset(name, data=data, **opts)
            d.attrs["MATLAB_class"] = np.bytes_(cls)
    text = (
        b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 "
        b"HDF5 schema 1.00 ."
    )
    header = text.ljust(116, b" ") + b"\0" * 8 + struct.pack("<H", 0x0200) + b"IM"
    with open(path, "r+b") as f:
        f.write(header.ljust(512, b"\0"))


def main():
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    for tag, dtype in [("c64", np.complex64), ("c128", np.complex128),
                       ("f32", np.float32), ("f64", np.float64)]:
        a = stack(dtype)
        np.save(out / f"{tag}.npy", a)
        scipy.io.savemat(out / f"{tag}.mat", {"x": a}, do_compression=False)
        scipy.io.savemat(out / f"{tag}_z.mat", {"x": a}, do_compression=True)
        if tag in ("c64", "f64"):
            be_v5(out / f"{tag}_be.mat", "x", a)
            back = scipy.io.loadmat(out / f"{tag}_be.mat")["x"]
            assert back.shape == a.shape and np.array_equal(back, a), "big-endian writer"
        if tag in ("c64", "c128", "f32"):
            v73(out / f"{tag}_v73.mat", {"x": a}, chunked=False)
            v73(out / f"{tag}_v73z.mat", {"x": a}, chunked=True)
    # Two stacks and a scalar: the variable must be named.
    a, b = stack(np.complex64), stack(np.float64)
    scipy.io.savemat(out / "two.mat", {"first": a, "second": b, "scale": 2.0})
    # One good stack next to everything that is not a numeric 3-D array.
    scipy.io.savemat(out / "mixed.mat", {
        "stack": a,
        "st": {"a": 1.0, "b": np.arange(3.0)},
        "ce": np.array([np.arange(2.0), "text"], dtype=object),
        "ch": "a char array",
        "sp": scipy.sparse.csc_matrix(np.eye(4)),
        "m2": np.ones((4, 5)),
    }, do_compression=True)
    # A scalar and a 2-D array alone: no stack at all.
    scipy.io.savemat(out / "flat.mat", {"m2": np.ones((4, 5))})
    # HDF5 without the MAT header: not a MAT file.
    import h5py

    with h5py.File(out / "plain.h5", "w") as f:
        f.create_dataset("x", data=stack(np.float64).T)


if __name__ == "__main__":
    main()

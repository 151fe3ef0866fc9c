"""MATLAB .mat fixtures for tests/mat.rs, written into the folder given on the command line.

The files are what MATLAB users meet: MAT v5 files written by SciPy's `scipy.io.savemat`
(complex64, complex128, float32, float64, int16; compressed and not), a big-endian v5 file
written here byte by byte (SciPy writes native order only; read back by SciPy to prove it),
files holding every kind the reader must refuse (struct, cell, char, sparse, 2-D), and h5py
files in MATLAB's v7.3 conventions (512-byte user block with the MATLAB header text,
dimensions reversed, complex as a compound of `real` and `imag`, a `MATLAB_class` attribute;
contiguous and deflate-chunked; structs as groups, cells as references into `#refs#`, char as
uint16, sparse as a group of `data`/`ir`/`jc` with `MATLAB_sparse`, logical, empty arrays with
`MATLAB_empty`), plus HDF5 files that are not MAT files (with and without a user block). Every
stack also goes to `<name>.npy` with the same values, H x W x N in C order, for a
value-for-value comparison.

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


MATLAB_CLASS = {np.float32: "single", np.float64: "double", np.int16: "int16"}


def v73_header(path):
    """Writes MATLAB's v7.3 header into the first 128 bytes of the user block of `path`."""
    text = (
        b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 "
        b"HDF5 schema 1.00 ."
    )
    header = text.ljust(116, b" ") + b"\0" * 8 + struct.pack("<H", 0x0200) + b"IM"
    with open(path, "r+b") as f:
        f.write(header.ljust(512, b"\0"))


def v73(path, variables, chunked):
    """An HDF5 file in MATLAB v7.3 conventions holding `variables` (name -> numeric array)."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        for name, a in variables.items():
            cls = MATLAB_CLASS[np.real(a).dtype.type]
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
    v73_header(path)


def v73_mixed(path):
    """A v7.3 file holding one stack next to every kind that is not a numeric 3-D array, as
    MATLAB stores them."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        a = stack(np.complex64).T
        c = np.empty(a.shape, dtype=[("real", "<f4"), ("imag", "<f4")])
        c["real"], c["imag"] = a.real, a.imag
        f.create_dataset("stack", data=c).attrs["MATLAB_class"] = np.bytes_("single")
        st = f.create_group("st")
        st.attrs["MATLAB_class"] = np.bytes_("struct")
        st.create_dataset("a", data=np.ones((1, 1))).attrs["MATLAB_class"] = np.bytes_("double")
        refs = f.create_group("#refs#")
        r1 = refs.create_dataset("a", data=np.arange(2.0).reshape(2, 1))
        r1.attrs["MATLAB_class"] = np.bytes_("double")
        r2 = refs.create_dataset("b", data=np.frombuffer(b"text", np.uint8).astype(np.uint16)
                                 .reshape(4, 1))
        r2.attrs["MATLAB_class"] = np.bytes_("char")
        ce = f.create_dataset("ce", (2, 1), dtype=h5py.ref_dtype)
        ce[0, 0], ce[1, 0] = r1.ref, r2.ref
        ce.attrs["MATLAB_class"] = np.bytes_("cell")
        ch = f.create_dataset("ch", data=np.frombuffer(b"a char array", np.uint8)
                              .astype(np.uint16).reshape(12, 1))
        ch.attrs["MATLAB_class"] = np.bytes_("char")
        ch.attrs["MATLAB_int_decode"] = np.int32(2)
        sp = f.create_group("sp")
        sp.attrs["MATLAB_class"] = np.bytes_("double")
        sp.attrs["MATLAB_sparse"] = np.uint64(4)
        sp.create_dataset("data", data=np.ones(4))
        sp.create_dataset("ir", data=np.arange(4, dtype=np.uint64))
        sp.create_dataset("jc", data=np.arange(5, dtype=np.uint64))
        m2 = f.create_dataset("m2", data=np.ones((4, 5)).T)
        m2.attrs["MATLAB_class"] = "double"  # a variable-length string, as some writers do
        lg = f.create_dataset("lg", data=np.ones((2, 3, 4), np.uint8).T)
        lg.attrs["MATLAB_class"] = np.bytes_("logical")
        em = f.create_dataset("em", data=np.array([0, 3], np.uint64))
        em.attrs["MATLAB_class"] = np.bytes_("double")
        em.attrs["MATLAB_empty"] = np.uint8(1)
    v73_header(path)


def main():
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    for tag, dtype in [("c64", np.complex64), ("c128", np.complex128),
                       ("f32", np.float32), ("f64", np.float64), ("i16", np.int16)]:
        a = stack(dtype)
        # The tool reads float and complex .npy; integer data go there as float64.
        np.save(out / f"{tag}.npy", a.astype(np.float64) if tag == "i16" else a)
        scipy.io.savemat(out / f"{tag}.mat", {"x": a}, do_compression=False)
        scipy.io.savemat(out / f"{tag}_z.mat", {"x": a}, do_compression=True)
        if tag in ("c64", "f64"):
            be_v5(out / f"{tag}_be.mat", "x", a)
            back = scipy.io.loadmat(out / f"{tag}_be.mat")["x"]
            assert back.shape == a.shape and np.array_equal(back, a), "big-endian writer"
        if tag in ("c64", "c128", "f32", "i16"):
            v73(out / f"{tag}_v73.mat", {"x": a}, chunked=False)
            v73(out / f"{tag}_v73z.mat", {"x": a}, chunked=True)
    # A measured-like stack for specs, fit and generate: 16 x 16 x 40 correlated complex64.
    rng = np.random.default_rng(17)
    z = rng.standard_normal((17, 17, 40)) + 1j * rng.standard_normal((17, 17, 40))
    m = (z[:-1, :-1] + 0.6 * z[1:, :-1] + 0.3 * z[:-1, 1:]).astype(np.complex64)
    np.save(out / "measured_hwn.npy", m)
    scipy.io.savemat(out / "measured.mat", {"clutter": m, "note": "16x16x40"},
                     do_compression=True)
    v73(out / "measured_v73.mat", {"clutter": m}, chunked=True)
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
    # The same in v7.3, and two stacks.
    v73_mixed(out / "mixed_v73.mat")
    v73(out / "two_v73.mat", {"first": a, "second": b}, chunked=False)
    # HDF5 without the MAT header: not a MAT file (with and without a user block).
    import h5py

    with h5py.File(out / "plain.h5", "w") as f:
        f.create_dataset("x", data=stack(np.float64).T)
    with h5py.File(out / "plain_ub.mat", "w", userblock_size=512) as f:
        f.create_dataset("x", data=stack(np.float64).T)


if __name__ == "__main__":
    main()

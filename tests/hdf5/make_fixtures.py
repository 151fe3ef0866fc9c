"""HDF5 fixtures for tests/hdf5.rs, written with h5py and numpy (not by the tool).

`stack.h5` holds one complex64 stack [4, 16, 12] in the forms HDF5 files use:
`/science/slc/HH` (h5py's complex compound {r, i}, chunked a sample at a time and gzip
compressed), `/pairs` (float32 [4, 16, 12, 2]: real, imaginary), `/re` and `/im` (float64
real and imaginary parts), `/hwn` (complex128 [16, 12, 4], samples last), `/matlab` (a
compound of float32 `real` and `imag`, MATLAB's names), `/hwn_chunked` (complex64 [16, 12,
4], chunked and gzip compressed), `/pairs_hwn` (float32 pairs, samples last, chunked),
`/complex_be` (big-endian complex64), `/shuffled` (gzip'd and shuffled in chunks that
leave partial ones at every edge), `/c128_chunked`, `/pairs_chunked` (float pairs, chunked,
shuffled), `/fletcher` (chunks with checksums); `/ints` (a chunked compound of int16 `r` and `i`, the
stack times 1000 rounded; `/ints_be` the same big-endian and contiguous) with `ints.npy`,
and `/real32` (the real parts alone, float32) with `real32.npy`; and what the
refusals need: `/text` (strings), `/scene` (a single [16, 12] scene), `/im_short` (float64 of
another shape), and `/frame/VV`, a single complex64 [40, 30] scene chunked 8 x 8 and gzip
compressed (an OPERA CSLC frame's form), with its column and row centres in UTM metres
beside it (`/frame/x_coordinates`, 5 m apart from 500002.5; `/frame/y_coordinates`, -10 m apart
from 4199995). `stack.npy` is the stack as h5py reads
`/science/slc/HH` back, `frame.npy` the scene as h5py reads `/frame/VV` back; `truncated.h5`
the first half of `stack.h5`'s bytes; `iceye.h5` an ICEYE SLC's form (`s_i`, `s_q`, int16,
and `calibration_factor`) with `iceye_beta0.npy` its scene calibrated to beta0 by numpy;
`userblock.h5` the stack (contiguous, chunked gzip'd
and shuffled, chunked plain) and the frame (chunked) behind a 512-byte user block.

Usage: python make_fixtures.py OUT_DIR
"""

import sys
from pathlib import Path

import h5py
import numpy as np


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20261129)
    shape = (4, 16, 12)
    x = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(np.complex64)
    with h5py.File(out / "stack.h5", "w") as f:
        f.create_dataset("science/slc/HH", data=x, chunks=(1, 16, 12), compression="gzip")
        f["pairs"] = np.stack([x.real, x.imag], axis=-1).astype(np.float32)
        f["re"] = x.real.astype(np.float64)
        f["im"] = x.imag.astype(np.float64)
        f["hwn"] = np.ascontiguousarray(np.transpose(x, (1, 2, 0))).astype(np.complex128)
        parts = np.empty(shape, dtype=[("real", "<f4"), ("imag", "<f4")])
        parts["real"], parts["imag"] = x.real, x.imag
        f["matlab"] = parts
        # Read in blocks (samples last, chunked) or with libhdf5's conversion (int16).
        f.create_dataset("hwn_chunked", data=np.transpose(x, (1, 2, 0)), chunks=(8, 6, 3),
                         compression="gzip")
        f.create_dataset("pairs_hwn", data=np.stack([x.real, x.imag], axis=-1)
                         .transpose(1, 2, 0, 3).astype(np.float32), chunks=(16, 12, 3, 2))
        ints = np.empty(shape, dtype=[("r", "<i2"), ("i", "<i2")])
        ints["r"], ints["i"] = np.round(x.real * 1000), np.round(x.imag * 1000)
        f.create_dataset("ints", data=ints, chunks=(3, 16, 12))
        f["ints_be"] = ints.astype([("r", ">i2"), ("i", ">i2")])
        # Chunks inflated on every core: partial chunks at every edge, shuffled, complex128,
        # float pairs; and a checksum (read by libhdf5).
        f.create_dataset("shuffled", data=x, chunks=(3, 5, 7), compression="gzip", shuffle=True)
        f.create_dataset("c128_chunked", data=x.astype(np.complex128), chunks=(2, 16, 12),
                         compression="gzip")
        f.create_dataset("pairs_chunked", data=np.stack([x.real, x.imag], axis=-1),
                         chunks=(3, 7, 5, 2), compression="gzip", shuffle=True)
        f.create_dataset("fletcher", data=x, chunks=(2, 8, 12), compression="gzip",
                         fletcher32=True)
        f["real32"] = x.real
        f["complex_be"] = x.astype(">c8")
        f["text"] = np.array([b"abc"] * 6).reshape(1, 2, 3)
        f["scene"] = x[0]
        f["im_short"] = x.imag[:3].astype(np.float64)
        frame = rng.standard_normal((40, 30)) + 1j * rng.standard_normal((40, 30))
        f.create_dataset("frame/VV", data=frame.astype(np.complex64), chunks=(8, 8),
                         compression="gzip")
        # Its column and row centres in UTM metres, as OPERA's CSLC stores them beside it.
        f["frame/x_coordinates"] = 500_000.0 + 5.0 * (np.arange(30) + 0.5)
        f["frame/y_coordinates"] = 4_200_000.0 - 10.0 * (np.arange(40) + 0.5)
    # A file with a 512-byte user block before its HDF5 data (h5py's userblock_size): libhdf5's
    # chunk addresses count from its end, a contiguous dataset's offset from the file's start.
    with h5py.File(out / "userblock.h5", "w", userblock_size=512) as f:
        f["contig"] = x
        f.create_dataset("chunked", data=x, chunks=(3, 5, 7), compression="gzip", shuffle=True)
        f.create_dataset("plain_chunks", data=x, chunks=(3, 5, 7))
        f.create_dataset("frame", data=frame.astype(np.complex64), chunks=(8, 8))
    # An ICEYE SLC's form (as sarpy's ICEYE reader reads it): int16 real and imaginary parts
    # `s_i`, `s_q` of one scene and the scalar `calibration_factor` (beta0 = factor |value|^2);
    # `iceye_beta0.npy` the scene calibrated by numpy in float32 (the factor's root rounded to a
    # float32, times each part).
    ints_scene = rng.integers(-2000, 2000, (2, 40, 30)).astype(np.int16)
    factor = 3.7e-7
    with h5py.File(out / "iceye.h5", "w") as f:
        f["s_i"], f["s_q"] = ints_scene[0], ints_scene[1]
        f["calibration_factor"] = factor
    scene = (ints_scene[0] + 1j * ints_scene[1]).astype(np.complex64)
    np.save(out / "iceye_beta0.npy", scene * np.float32(np.sqrt(factor)))
    with h5py.File(out / "stack.h5", "r") as f:
        np.save(out / "stack.npy", f["science/slc/HH"][...])
        np.save(out / "frame.npy", f["frame/VV"][...])
        ints = f["ints"][...]
        np.save(out / "ints.npy", (ints["r"] + 1j * ints["i"]).astype(np.complex64))
        np.save(out / "real32.npy", f["real32"][...])
    data = (out / "stack.h5").read_bytes()
    (out / "truncated.h5").write_bytes(data[: len(data) // 2])


if __name__ == "__main__":
    main(Path(sys.argv[1]))

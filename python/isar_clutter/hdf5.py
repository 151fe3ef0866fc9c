"""HDF5 stacks and scenes for ``isar_clutter.load``, read with h5py.

The command line's ``kind: hdf5`` reads the same files with libhdf5 linked into the binary;
the Python extension is built without it (a second copy of the library in every wheel), so
here the field's own Python reader, h5py, reads them, with the same forms and checks: a
dataset at a path in the file holding complex compounds (``{r, i}`` as h5py and NISAR write
them, ``{real, imag}``, ``{re, im}``), real numbers (with the imaginary parts in ``imag``, or
none) or float pairs (a last dimension of 2); a stack ``[N, H, W]`` (``[H, W, N]`` with
``layout="hwn"``) or a single scene ``[H, W]``, read in ``window``.
"""

import os
from typing import Optional, Tuple

import numpy as np

#: The field names of the complex compounds read.
COMPOUND_NAMES = [("r", "i"), ("real", "imag"), ("re", "im")]


def _single(dtype: np.dtype) -> bool:
    """Whether every number of ``dtype`` fits a float32 exactly (the result is complex64)."""
    if dtype.names:
        return all(_single(dtype.fields[n][0]) for n in dtype.names)
    if dtype.kind == "f":
        return dtype.itemsize <= 4
    return dtype.kind in "iu" and dtype.itemsize <= 2


def _is_number(dtype: np.dtype) -> bool:
    return dtype.kind in "fiu"


def load_hdf5(
    path: str,
    dataset: Optional[str],
    imag: Optional[str] = None,
    layout: str = "nhw",
    window: Optional[Tuple[int, int, int, int]] = None,
    map_box: Optional[Tuple[Tuple[float, float], Tuple[float, float]]] = None,
) -> np.ndarray:
    """The stack ``dataset`` of the HDF5 file ``path`` as ``[N, H, W]`` (see the module).

    A single scene's window may instead be ``map_box`` ``((x0, x1), (y0, y1))`` in the map
    coordinates of the vectors of its column and row centres beside it in its group
    (``x_coordinates``/``y_coordinates``, OPERA's; ``xCoordinates``/``yCoordinates``,
    NISAR's; ``x``/``y``): the pixels that cover the box, as the command line's ``hdf5`` kind
    places a map ``window``.

    complex64 where the stored numbers fit a float32 (floats of 4 bytes, integers of 2),
    complex128 otherwise. A single scene ``[H, W]`` gives ``[1, h, w]``, its ``window``
    ``(row, col, rows, cols)`` (default: the whole scene). A bad file raises ``ValueError``
    naming the field (``path``, ``dataset``, ``imag``, ``layout``, ``window``) and the file.
    """
    try:
        import h5py
    except ImportError as e:  # pragma: no cover - h5py is in the test environment
        raise ImportError("isar_clutter.load reads HDF5 with h5py: pip install h5py") from e
    path = os.fspath(path)
    if not dataset:
        raise ValueError(f"dataset: {path}: give the stack's path in the file (dataset=...)")
    if layout not in ("nhw", "hwn"):
        raise ValueError(f"layout: {layout!r}: nhw or hwn")
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise ValueError(
            f"path: {path}: h5py cannot open it (not HDF5, or truncated?): {e}"
        ) from e
    with f:
        ds = _dataset(f, path, dataset, "dataset")
        t = ds.dtype
        if t.names:
            names = tuple(t.names)
            if names not in COMPOUND_NAMES or not all(_is_number(t.fields[n][0]) for n in names):
                raise ValueError(
                    f"dataset: {path}: {dataset!r} holds a compound of {', '.join(names)}; "
                    "complex data are a compound of two numbers named r and i, real and imag, "
                    "or re and im"
                )
            form = "compound"
        elif t.kind == "c":
            form = "complex"
        elif _is_number(t):
            form = "pairs" if ds.ndim == 4 and ds.shape[3] == 2 else "real"
        else:
            raise ValueError(f"dataset: {path}: {dataset!r} holds {t}, not numbers")
        dims = ds.shape[:3] if form == "pairs" else ds.shape
        im = None
        if imag is not None:
            im = _dataset(f, path, imag, "imag")
            if form != "real" or not _is_number(im.dtype):
                raise ValueError(
                    f"imag: {path}: with imag {imag!r}, {dataset!r} and {imag!r} must both "
                    "hold real numbers"
                )
            if im.shape != ds.shape:
                raise ValueError(
                    f"imag: {path}: {imag!r} has dimensions {list(im.shape)}, {dataset!r} "
                    f"{list(ds.shape)}: the real and imaginary parts must have one shape"
                )
        single = _single(t) and (im is None or _single(im.dtype))
        out_type = np.complex64 if single and form != "complex" else (
            t if form == "complex" else np.complex128
        )
        if len(dims) == 2:
            if map_box is not None:
                if window is not None:
                    raise ValueError("window: give window= or map_box=, not both")
                window = _map_window(f, path, dataset, dims, map_box)
            r0, c0, h, w = window if window is not None else (0, 0, dims[0], dims[1])
            if min(r0, c0) < 0 or h < 1 or w < 1 or r0 + h > dims[0] or c0 + w > dims[1]:
                raise ValueError(
                    f"window: {path}: rows {r0}..{r0 + h} x columns {c0}..{c0 + w} is not "
                    f"inside the scene {list(dims)}"
                )
            sel = (slice(r0, r0 + h), slice(c0, c0 + w))
            values = _complex(ds[sel], im[sel] if im is not None else None, form, out_type)
            return values[np.newaxis]
        if len(dims) != 3:
            raise ValueError(
                f"dataset: {path}: {dataset!r} has dimensions {list(ds.shape)}: a stack is "
                "[N, H, W] (or [H, W, N]; float pairs [N, H, W, 2]), a scene [H, W]"
            )
        if window is not None:
            raise ValueError(f"window: applies to a single scene [H, W]; {dataset!r} is a stack")
        values = _complex(ds[...], im[...] if im is not None else None, form, out_type)
        if layout == "hwn":
            values = np.ascontiguousarray(np.moveaxis(values, 2, 0))
        return values


COORDINATE_NAMES = [("x_coordinates", "y_coordinates"), ("xCoordinates", "yCoordinates"),
                    ("x", "y")]


def _map_window(f, path: str, dataset: str, dims, map_box):
    """``(row, col, rows, cols)`` covering ``map_box`` through the coordinate vectors beside
    the scene ``dataset`` (their centres; corners half a spacing before), rounded outwards."""
    group = f[dataset].parent
    for xn, yn in COORDINATE_NAMES:
        if xn in group and yn in group:
            x, y = group[xn][...].astype(np.float64), group[yn][...].astype(np.float64)
            break
    else:
        raise ValueError(
            f"window: {path}: {dataset} has no coordinate vectors beside it in {group.name} "
            "(x_coordinates/y_coordinates, xCoordinates/yCoordinates or x/y)"
        )
    if len(x) != dims[1] or len(y) != dims[0] or len(x) < 2 or len(y) < 2:
        raise ValueError(f"window: {path}: the coordinate vectors are not the scene's size")
    dx, dy = (x[-1] - x[0]) / (len(x) - 1), (y[-1] - y[0]) / (len(y) - 1)
    # An affine grid, as the command line's io/h5stack/coords.rs requires (1e-6 of a spacing).
    for v, d, name in ((x, dx, "x"), (y, dy, "y")):
        even = v[0] + d * np.arange(len(v))
        if d == 0 or not np.isfinite(d) or np.any(~(np.abs(v - even) <= 1e-6 * abs(d))):
            raise ValueError(
                f"window: {path}: {dataset}'s {name} coordinates are not evenly spaced "
                "(an affine grid is needed)"
            )
    (bx0, bx1), (by0, by1) = map_box
    cols = [(v - (x[0] - dx / 2)) / dx for v in (bx0, bx1)]
    rows = [(v - (y[0] - dy / 2)) / dy for v in (by0, by1)]

    def snap(v):
        return round(v) if abs(v - round(v)) < 1e-6 else v

    r0, r1 = int(np.floor(snap(min(rows)))), int(np.ceil(snap(max(rows))))
    c0, c1 = int(np.floor(snap(min(cols)))), int(np.ceil(snap(max(cols))))
    return (r0, c0, r1 - r0, c1 - c0)


def _dataset(f, path: str, name: str, field: str):
    import h5py

    obj = f.get(name)
    if not isinstance(obj, h5py.Dataset):
        members = ", ".join(f.keys()) or "nothing"
        raise ValueError(
            f"{field}: {path}: no dataset {name!r} (the file's top level holds: {members}; "
            "give the full path, as /group/dataset)"
        )
    return obj


def _complex(v: np.ndarray, im: Optional[np.ndarray], form: str, out_type) -> np.ndarray:
    """The stored values ``v`` (and imaginary parts ``im``) as complex ``out_type``."""
    out_type = np.dtype(out_type).newbyteorder("=")
    part = np.float32 if out_type == np.complex64 else np.float64
    if form == "complex":
        return v.astype(out_type)
    out = np.empty(v.shape[:-1] if form == "pairs" else v.shape, dtype=out_type)
    if form == "compound":
        re_name, im_name = v.dtype.names
        out.real, out.imag = v[re_name].astype(part), v[im_name].astype(part)
    elif form == "pairs":
        out.real, out.imag = v[..., 0].astype(part), v[..., 1].astype(part)
    else:
        out.real = v.astype(part)
        out.imag = im.astype(part) if im is not None else 0
    return out

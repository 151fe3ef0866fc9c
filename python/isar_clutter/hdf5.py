"""HDF5 stacks and scenes for ``isar_clutter.load``, read with h5py.

The command line's ``kind: hdf5`` reads the same files with libhdf5 linked into the binary;
the Python extension is built without it (a second copy of the library in every wheel), so
here the field's own Python reader, h5py, reads them, with the same forms and checks: a
dataset at a path in the file holding complex compounds (``{r, i}`` as h5py and NISAR write
them, ``{real, imag}``, ``{re, im}``), real numbers (with the imaginary parts in ``imag``, or
none) or float pairs (a last dimension of 2); a stack ``[N, H, W]`` (``[H, W, N]`` with
``layout="hwn"``) or a single scene ``[H, W]``, read in ``window`` and calibrated with
the product's own scale factors as the command line's ``calibration`` calibrates it (NISAR's
calibration tables, ICEYE's ``calibration_factor``; docs/spec.md).
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
    calibration: Optional[str] = None,
) -> np.ndarray:
    """The stack ``dataset`` of the HDF5 file ``path`` as ``[N, H, W]`` (see the module).

    A single scene's window may instead be ``map_box`` ``((x0, x1), (y0, y1))`` in the map
    coordinates of the vectors of its column and row centres beside it in its group
    (``x_coordinates``/``y_coordinates``, OPERA's; ``xCoordinates``/``yCoordinates``,
    NISAR's; ``x``/``y``), else through a NISAR RSLC product's geolocation grid at its
    reference terrain height: the pixels that cover the box, as the command line's ``hdf5``
    kind places a map ``window``.

    A single scene may be calibrated (``calibration``: ``"beta0"``, ``"sigma0"``,
    ``"gamma0"``) so that ``|x|**2`` is that quantity: by NISAR's table of it where a group
    above the scene holds ``metadata/calibrationInformation/geometry`` (each value divided by
    the table read bilinearly at its pixel, clamped to the table's grid), else ``beta0`` by
    ICEYE's ``/calibration_factor`` (each value times its square root).

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
            if calibration is not None:
                values = _calibrate(f, path, dataset, dims, calibration, sel, values)
            return values[np.newaxis]
        if len(dims) != 3:
            raise ValueError(
                f"dataset: {path}: {dataset!r} has dimensions {list(ds.shape)}: a stack is "
                "[N, H, W] (or [H, W, N]; float pairs [N, H, W, 2]), a scene [H, W]"
            )
        if window is not None or calibration is not None:
            field = "window" if window is not None else "calibration"
            raise ValueError(f"{field}: applies to a single scene [H, W]; {dataset!r} is a stack")
        values = _complex(ds[...], im[...] if im is not None else None, form, out_type)
        if layout == "hwn":
            values = np.ascontiguousarray(np.moveaxis(values, 2, 0))
        return values


#: The group of a NISAR product holding its calibration tables.
TABLES = "metadata/calibrationInformation/geometry"
#: The names of a table's (row, column) axes: an RSLC's, a GSLC's.
TABLE_AXES = [("zeroDopplerTime", "slantRange"), ("yCoordinates", "xCoordinates")]


def _ancestors(name: str):
    """The groups above the dataset ``name``, nearest first, ending with the root."""
    parts = [p for p in name.split("/") if p]
    return ["/" + "/".join(parts[:k]) for k in range(len(parts) - 1, -1, -1)]


def _join(group: str, name: str) -> str:
    return f"{group.rstrip('/')}/{name}"


def _place(axis: np.ndarray, x: np.ndarray):
    """For each coordinate ``x``: the index of the grid point of ``axis`` at or before it
    and the share of the way to the next, clamped to the grid's ends."""
    n = len(axis)
    if n == 1:
        return np.zeros(len(x), dtype=np.intp), np.zeros(len(x))
    sign = 1.0 if axis[-1] > axis[0] else -1.0
    before = np.searchsorted(sign * axis, sign * x, side="right")
    i = np.clip(before, 1, n - 1) - 1
    return i, np.clip((x - axis[i]) / (axis[i + 1] - axis[i]), 0.0, 1.0)


def _calibrate(f, path: str, dataset: str, dims, quantity: str, sel, values) -> np.ndarray:
    """``values``, the window ``sel`` of the scene, calibrated to ``quantity``."""
    groups = _ancestors(dataset)
    roots = [k for k, g in enumerate(groups) if _join(g, TABLES) in f]
    if not roots:
        if quantity != "beta0":
            raise ValueError(
                f"calibration: {path}: no group above {dataset} holds NISAR's calibration "
                f"tables ({TABLES}), and ICEYE's calibration_factor gives beta0 only "
                f"(asked for {quantity})"
            )
        if "calibration_factor" not in f:
            raise ValueError(
                f"calibration: {path}: its HDF5 holds no /calibration_factor (ICEYE's beta0 "
                f"scale factor) and no group above {dataset} holds NISAR's {TABLES}"
            )
        factor = float(np.asarray(f["calibration_factor"][()]))
        if not (np.isfinite(factor) and factor > 0):
            raise ValueError(f"calibration: {path}: /calibration_factor is {factor}")
        return values * np.float32(np.sqrt(factor))
    root = roots[0]
    tables = _join(groups[root], TABLES)
    g = f[tables]
    if quantity not in g:
        held = sorted(n for n in g if n in ("beta0", "sigma0", "gamma0"))
        raise ValueError(f"calibration: {path}: {tables} holds no {quantity} table (it holds {held})")
    names = next(((r, c) for r, c in TABLE_AXES if r in g and c in g), None)
    if names is None:
        raise ValueError(f"calibration: {path}: {tables} has no axes for its tables")

    def units(d):
        u = d.attrs.get("units")
        return u.decode() if isinstance(u, bytes) else u

    axes, coords = [], []
    for name, n, side in zip(names, dims, ("rows", "columns")):
        table_axis = g[name]
        place = next((p for p in groups[: root + 1] if _join(p, name) in f), None)
        if place is None:
            raise ValueError(
                f"calibration: {path}: no {name} beside {dataset}, to place "
                f"{tables}/{quantity} on its pixels"
            )
        beside = f[_join(place, name)]
        if beside.shape != (n,):
            raise ValueError(
                f"calibration: {path}: {beside.name} holds {beside.size} values for the "
                f"scene's {n} {side}"
            )
        a, b = units(table_axis), units(beside)
        if a is not None and b is not None and a.strip() != b.strip():
            raise ValueError(
                f"calibration: {path}: {table_axis.name} is in {a!r} but {beside.name} in "
                f"{b!r}: the table and the scene must share their axes' units (and epoch)"
            )
        axes.append(table_axis[...].astype(np.float64))
        coords.append(beside[...].astype(np.float64))
    table = g[quantity][...].astype(np.float64)
    if table.shape != (len(axes[0]), len(axes[1])):
        raise ValueError(
            f"calibration: {path}: {tables}/{quantity} has dimensions {list(table.shape)}, "
            f"its axes {len(axes[0])} and {len(axes[1])}"
        )
    if not np.all(np.isfinite(table) & (table > 0)):
        raise ValueError(
            f"calibration: {path}: {tables}/{quantity} holds values that are not positive "
            "numbers"
        )
    ri, ru = _place(axes[0], coords[0][sel[0]])
    ci, cu = _place(axes[1], coords[1][sel[1]])
    i1 = np.minimum(ri + 1, table.shape[0] - 1)
    j1 = np.minimum(ci + 1, table.shape[1] - 1)
    top = table[ri][:, ci] * (1 - cu) + table[ri][:, j1] * cu
    bottom = table[i1][:, ci] * (1 - cu) + table[i1][:, j1] * cu
    at = top * (1 - ru)[:, None] + bottom * ru[:, None]
    return values / at.astype(np.float32)


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
        grid = _geolocation_window(f, path, dataset, dims, map_box)
        if grid is not None:
            return grid
        raise ValueError(
            f"window: {path}: {dataset} has no coordinate vectors beside it in {group.name} "
            "(x_coordinates/y_coordinates, xCoordinates/yCoordinates or x/y) and no group "
            "above it holds NISAR's metadata/geolocationGrid"
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


#: Where a NISAR product keeps its geolocation grid and its processor's terrain heights.
GEOLOCATION = "metadata/geolocationGrid"
TERRAIN = "metadata/processingInformation/parameters/referenceTerrainHeight"


def _index(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Fractional indices of ``t`` along the axis ``v``, linear between and beyond its values."""
    sign = 1.0 if v[-1] > v[0] else -1.0
    i = np.clip(np.searchsorted(sign * v, sign * t, side="right"), 1, len(v) - 1) - 1
    return i + (t - v[i]) / (v[i + 1] - v[i])


def _position(nodes: np.ndarray, t: float) -> float:
    """The fractional node index ``t`` as a pixel position: linear between the nodes'
    positions ``nodes``, extended from the end pairs."""
    i = min(max(int(np.floor(t)), 0), len(nodes) - 2)
    return float(nodes[i] + (t - i) * (nodes[i + 1] - nodes[i]))


def _geolocation_window(f, path: str, dataset: str, dims, map_box):
    """``(row, col, rows, cols)`` covering ``map_box`` through the NISAR RSLC product's
    geolocation grid above ``dataset`` at its reference terrain height (as the command line's
    io/h5stack/geolocation.rs and io/geogrid.rs place it), ``None`` without one."""
    groups = _ancestors(dataset)
    roots = [k for k, g in enumerate(groups) if _join(g, GEOLOCATION + "/coordinateX") in f]
    if not roots:
        return None
    root = groups[roots[0]]
    g = f[_join(root, GEOLOCATION)]
    times, ranges = g["zeroDopplerTime"][...], g["slantRange"][...]
    heights = g["heightAboveEllipsoid"][...].astype(np.float64)
    terrain = f[_join(root, TERRAIN)][...] if _join(root, TERRAIN) in f else np.array([])
    terrain = terrain[np.isfinite(terrain)]
    h = float(terrain.mean()) if terrain.size else 0.0
    # The two layers around the height (only they are read), linear between them.
    if len(heights) == 1:
        k, k1, w = 0, 0, 0.0
    else:
        k = int(np.clip(np.searchsorted(heights, h, side="right"), 1, len(heights) - 1)) - 1
        k1 = k + 1
        w = float(np.clip((h - heights[k]) / (heights[k1] - heights[k]), 0.0, 1.0))
    layer = []
    for name in ("coordinateX", "coordinateY"):
        two = g[name][k : k1 + 1].astype(np.float64)
        layer.append(two[0] * (1 - w) + two[-1] * w)
    beside = []
    for name, n in (("zeroDopplerTime", dims[0]), ("slantRange", dims[1])):
        place = next((p for p in groups[: roots[0] + 1] if _join(p, name) in f), None)
        if place is None or f[_join(place, name)].shape != (n,):
            raise ValueError(f"window: {path}: no {name} of the scene's size beside {dataset}")
        beside.append(f[_join(place, name)][...].astype(np.float64))
    node_rows = _index(beside[0], times) + 0.5
    node_cols = _index(beside[1], ranges) + 0.5
    m, n = len(node_rows), len(node_cols)

    def at(a, b):
        i, j = min(max(int(np.floor(a)), 0), m - 2), min(max(int(np.floor(b)), 0), n - 2)
        u, v = a - i, b - j
        p = [c[i : i + 2, j : j + 2] for c in layer]
        val = [q[0, 0] * (1 - u) * (1 - v) + q[0, 1] * (1 - u) * v + q[1, 0] * u * (1 - v)
               + q[1, 1] * u * v for q in p]
        da = [(q[1, 0] - q[0, 0]) * (1 - v) + (q[1, 1] - q[0, 1]) * v for q in p]
        db = [(q[0, 1] - q[0, 0]) * (1 - u) + (q[1, 1] - q[1, 0]) * u for q in p]
        return val, da, db

    def pixel(x, y):
        scale = max(abs(np.cos(np.radians(y))), 1e-9) if abs(y) <= 90 else 1.0
        d = ((layer[0] - x) * scale) ** 2 + (layer[1] - y) ** 2
        a, b = (float(t) for t in np.unravel_index(np.argmin(d), d.shape))
        for _ in range(60):
            val, da, db = at(a, b)
            rx, ry = x - val[0], y - val[1]
            det = da[0] * db[1] - db[0] * da[1]
            sa, sb = (rx * db[1] - db[0] * ry) / det, (da[0] * ry - rx * da[1]) / det
            a, b = a + sa, b + sb
            if max(abs(sa), abs(sb)) < 1e-10:
                if not (-1e-9 <= a <= m - 1 + 1e-9 and -1e-9 <= b <= n - 1 + 1e-9):
                    break
                return _position(node_rows, a), _position(node_cols, b)
        raise ValueError(f"window: {path}: the point ({x}, {y}) lies outside the geolocation grid")

    (x0, x1), (y0, y1) = map_box
    steps = np.arange(17) / 16
    edges = [(x0 + (x1 - x0) * t, yy) for t in steps for yy in (y0, y1)]
    edges += [(xx, y0 + (y1 - y0) * t) for t in steps for xx in (x0, x1)]
    placed = np.array([pixel(xx, yy) for xx, yy in edges])

    def snap(v):
        return round(v) if abs(v - round(v)) < 1e-6 else v

    r0, r1 = int(np.floor(snap(placed[:, 0].min()))), int(np.ceil(snap(placed[:, 0].max())))
    c0, c1 = int(np.floor(snap(placed[:, 1].min()))), int(np.ceil(snap(placed[:, 1].max())))
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

"""NISAR fixtures for tests/nisar.rs and python/tests/test_load.py, written with h5py, numpy and
scipy (not by the tool), in the layouts of isce3's product writers (NISAR's processor).

`rslc.h5`: an RSLC frame. `/science/LSAR/RSLC/swaths/frequencyA/HH` a complex64 [40, 30]
scene (chunked 8 x 8, gzip), its rows' zero-Doppler times `/science/LSAR/RSLC/swaths/
zeroDopplerTime` (seconds since an epoch, the `units` attribute as fixed-length bytes, as
isce3 writes it) and its columns' slant ranges `.../frequencyA/slantRange` (metres); the
calibration tables `/science/LSAR/RSLC/metadata/calibrationInformation/geometry/{beta0, sigma0,
gamma0}` (float32 [4, 4]: beta0 1, sigma0 and gamma0 `1/sqrt(sin)` and `1/sqrt(tan)` of an
incidence angle rising with range, scaled along time) over their own `zeroDopplerTime` (every
12 lines from 3 lines before the first) and `slantRange` (every 7 columns from the sixth), so
that rows after the 34th and columns outside 5..26 lie beyond the tables' grids.

`rslc.h5` also holds the frame's geolocation grid (`metadata/geolocationGrid`, as isce3 writes
it: `coordinateX`/`coordinateY` [heights, times, ranges] at `heightAboveEllipsoid` -500, 0, 500
and 1000 m over nodes every 9 lines and 8 columns with margins, `epsg` 4326) of a rotated,
slightly curved longitude/latitude map that shifts with height, and the processor's
`referenceTerrainHeight` (mean 200 m). `map_box.json`: a longitude/latitude box and the pixel
window that covers it (`[r0, r1, c0, c1]`, ends excluded) at 200 m, found by scipy: the grid's
two layers around 200 m interpolated linearly, read at a pixel by `RegularGridInterpolator`
over the nodes' times and ranges, and the box's corners placed by `scipy.optimize.fsolve`
(the box's edges are monotonic in rows and columns, so its corners bound them).

`gslc.h5`: a GSLC frame. `/science/LSAR/GSLC/grids/frequencyA/HH` complex64 [40, 30] with
`xCoordinates` (rising) and `yCoordinates` (falling: north up) beside it, and the tables in
`/science/LSAR/GSLC/metadata/calibrationInformation/geometry` over coarser `yCoordinates` (also
falling) and `xCoordinates`.

`rslc_sigma0.npy` and `gslc_gamma0.npy`: the scenes calibrated by the convention of ASF's
NISAR documentation (`sigma0 = |DN|^2 / sigma0_table^2`: each value divided by the table at
its pixel), the table read at each pixel by scipy's `RegularGridInterpolator` (linear) at the
pixel's coordinates clipped to the table's grid (isce3's `LUT2d` clamps so), rounded to
float32 and dividing the complex64 values.

`bad.h5`: RSLC frames that cannot be calibrated, one a group: `/epoch` (the scene's times in
seconds since another epoch than the tables'), `/no_time` (no zero-Doppler times beside the
scene), `/zero` (a sigma0 table with a 0), `/short` (29 slant ranges for 30 columns).

Usage: python make_nisar_fixtures.py OUT_DIR
"""

import json
import sys
from pathlib import Path

import h5py
import numpy as np
from scipy.interpolate import RegularGridInterpolator
from scipy.optimize import fsolve

ROWS, COLS = 40, 30
EPOCH = "seconds since 2025-11-01T00:00:00.000000000"


def axis(group, name, values, units):
    """A float64 axis with its units as isce3 writes them (fixed-length bytes)."""
    d = group.create_dataset(name, data=np.asarray(values, dtype=np.float64))
    d.attrs["units"] = np.bytes_(units)


def tables(group, axes, names, incidence, along):
    """The three tables over the axes `axes` named `names` (row, column) in `group`: the
    incidence angle rising linearly over the columns between the degrees `incidence`, the
    tables scaled along the rows by `along`."""
    row_axis, col_axis = axes
    axis(group, names[0], row_axis, EPOCH if names[0] == "zeroDopplerTime" else "meters")
    axis(group, names[1], col_axis, "meters")
    theta = np.radians(np.linspace(incidence[0], incidence[1], len(col_axis)))[None, :]
    scale = along[:, None]
    out = {
        "beta0": np.ones((len(row_axis), len(col_axis))),
        "sigma0": scale / np.sqrt(np.sin(theta)),
        "gamma0": scale / np.sqrt(np.tan(theta)),
    }
    for name, v in out.items():
        group[name] = v.astype(np.float32)
    return {k: v.astype(np.float32) for k, v in out.items()}


def calibrated(scene, row_axis, col_axis, table, rows, cols):
    """`scene` divided by `table` read at each pixel (clipped to its grid), in float32."""
    f = RegularGridInterpolator((row_axis, col_axis), table.astype(np.float64), method="linear")
    r = np.clip(rows, min(row_axis), max(row_axis))
    c = np.clip(cols, min(col_axis), max(col_axis))
    rr, cc = np.meshgrid(r, c, indexing="ij")
    at = f(np.stack([rr, cc], axis=-1))
    return (scene / at.astype(np.float32)).astype(np.complex64)


def rslc(root, scene, t0=1000.0, dt=0.002, r0=850_000.0, dr=3.5, time_units=EPOCH, n_ranges=COLS):
    """An RSLC frame in `root`; its axes and tables."""
    swaths = root.create_group("swaths")
    freq = swaths.create_group("frequencyA")
    freq.create_dataset("HH", data=scene, chunks=(8, 8), compression="gzip")
    t = t0 + dt * np.arange(ROWS)
    r = r0 + dr * np.arange(COLS)
    axis(swaths, "zeroDopplerTime", t, time_units)
    axis(freq, "slantRange", r[:n_ranges], "meters")
    geometry = root.create_group("metadata/calibrationInformation/geometry")
    lt = t0 + dt * (-3 + 12 * np.arange(4))
    lr = r0 + dr * (5 + 7 * np.arange(4))
    along = np.array([1.0, 1.03, 0.98, 1.05])
    made = tables(geometry, (lt, lr), ("zeroDopplerTime", "slantRange"), (30.0, 45.0), along)
    return (t, r, lt, lr, made)


HEIGHTS = np.array([-500.0, 0.0, 500.0, 1000.0])


def lonlat(row, col, h):
    """The map's longitude and latitude at pixel-centre indices (row, col) and height h:
    rotated about 20 degrees from the pixel axes, slightly curved, shifted with height."""
    lon = -121.9 + 2.0e-4 * col + 7.0e-5 * row + 3.0e-7 * col**2 + 1.0e-6 * h * (1 + 0.01 * col)
    lat = 37.4 - 1.8e-4 * row + 6.5e-5 * col - 2.0e-7 * row * col + 4.0e-7 * h
    return lon, lat


def geolocation(root, t, r):
    """isce3's geolocation grid of `lonlat` over nodes every 9 lines and 8 columns, with
    margins, and a reference terrain height; the map box and its window at that height."""
    grid = root.create_group("metadata/geolocationGrid")
    rows = -6.0 + 9.0 * np.arange(7)
    cols = -4.0 + 8.0 * np.arange(6)
    dt, dr = t[1] - t[0], r[1] - r[0]
    axis(grid, "zeroDopplerTime", t[0] + dt * rows, EPOCH)
    axis(grid, "slantRange", r[0] + dr * cols, "meters")
    axis(grid, "heightAboveEllipsoid", HEIGHTS, "meters")
    rr, cc = np.meshgrid(rows, cols, indexing="ij")
    cube = [lonlat(rr, cc, h) for h in HEIGHTS]
    grid["coordinateX"] = np.stack([c[0] for c in cube])
    grid["coordinateY"] = np.stack([c[1] for c in cube])
    grid["epsg"] = np.int32(4326)
    terrain = np.array([180.0, 220.0, 190.0, 210.0])
    root["metadata/processingInformation/parameters/referenceTerrainHeight"] = terrain
    rr_nodes = rows
    x, y = [-121.8970, -121.8951], [37.3979, 37.4003]

    def window_at(h):
        """The box's window with the grid's layers interpolated linearly at height h."""
        k = int(np.clip(np.searchsorted(HEIGHTS, h, side="right"), 1, len(HEIGHTS) - 1)) - 1
        w = (h - HEIGHTS[k]) / (HEIGHTS[k + 1] - HEIGHTS[k])
        layers = [grid[n][k] * (1 - w) + grid[n][k + 1] * w for n in ("coordinateX", "coordinateY")]
        maps = [RegularGridInterpolator((rr_nodes, cols), v, method="linear") for v in layers]

        def place(lon, lat):
            f = lambda p: [maps[0]([p])[0] - lon, maps[1]([p])[0] - lat]
            p = fsolve(f, [20.0, 15.0], xtol=1e-13)
            assert np.allclose(f(p), 0, atol=1e-12), f(p)
            return p + 0.5  # pixel-corner positions, as the tool counts them

        corners = np.array([place(lo, la) for lo in x for la in y])
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        ends = np.concatenate([lo, hi])
        assert np.all(np.abs(ends - np.round(ends)) > 1e-3), ends
        return [int(np.floor(lo[0])), int(np.ceil(hi[0])), int(np.floor(lo[1])), int(np.ceil(hi[1]))]

    window = window_at(terrain.mean())
    assert 0 <= window[0] < window[1] <= ROWS and 0 <= window[2] < window[3] <= COLS, window
    # The height matters: on the ellipsoid the box lands elsewhere.
    assert window_at(0.0) != window, window
    return {"x": x, "y": y, "window": window, "ellipsoid_window": window_at(0.0)}


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20261129)

    def scene():
        v = rng.standard_normal((ROWS, COLS)) + 1j * rng.standard_normal((ROWS, COLS))
        return (300.0 * v).astype(np.complex64)

    x = scene()
    with h5py.File(out / "rslc.h5", "w") as f:
        t, r, lt, lr, made = rslc(f.create_group("science/LSAR/RSLC"), x)
        box = geolocation(f["science/LSAR/RSLC"], t, r)
    (out / "map_box.json").write_text(json.dumps(box))
    np.save(out / "rslc_sigma0.npy", calibrated(x, lt, lr, made["sigma0"], t, r))

    g = scene()
    with h5py.File(out / "gslc.h5", "w") as f:
        root = f.create_group("science/LSAR/GSLC")
        freq = root.create_group("grids/frequencyA")
        freq.create_dataset("HH", data=g, chunks=(8, 8), compression="gzip")
        xs = 400_000.0 + 10.0 * (np.arange(COLS) + 0.5)
        ys = 3_800_000.0 - 5.0 * (np.arange(ROWS) + 0.5)
        axis(freq, "xCoordinates", xs, "meters")
        axis(freq, "yCoordinates", ys, "meters")
        geometry = root.create_group("metadata/calibrationInformation/geometry")
        lx = 400_000.0 + 60.0 * np.arange(6)
        ly = 3_800_010.0 - 50.0 * np.arange(5)
        along = np.array([1.0, 0.97, 1.02, 1.04, 0.99])
        made = tables(geometry, (ly, lx), ("yCoordinates", "xCoordinates"), (28.0, 44.0), along)
    np.save(out / "gslc_gamma0.npy", calibrated(g, ly, lx, made["gamma0"], ys, xs))

    with h5py.File(out / "bad.h5", "w") as f:
        rslc(f.create_group("epoch"), x, time_units="seconds since 2025-11-02T00:00:00.000000000")
        rslc(f.create_group("no_time"), x)
        del f["no_time/swaths/zeroDopplerTime"]
        rslc(f.create_group("zero"), x)
        table = f["zero/metadata/calibrationInformation/geometry/sigma0"]
        v = table[...]
        v[2, 1] = 0.0
        table[...] = v
        rslc(f.create_group("short"), x, n_ranges=COLS - 1)


if __name__ == "__main__":
    main(Path(sys.argv[1]))

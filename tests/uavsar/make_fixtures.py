"""UAVSAR fixtures for tests/uavsar.rs, written with numpy alone (not by the tool).

Three coregistered scenes of 40 rows x 30 columns, each a `.slc` of little-endian complex64
values named as UAVSAR names them (`<name>_s1_1x1.slc`) with its annotation `<name>.ann` in
UAVSAR's `key (unit) = value ; comment` form, and `window.npy`: rows 5..21 and columns 7..23
of each scene as numpy reads them, an [N, H, W] complex64 stack, and `scenes.npy`, the whole
scenes as numpy reads them. The flight line's latitude/longitude product `testsite_L090HH_01_BC_s1_2x8.llh`
(little-endian float32 latitude, longitude, height for every block of 2 range (column) x 8
azimuth (row) looks: 5 x 15 points, a rotated grid), named in every annotation, with
`map_box.json`, a box of longitude and latitude, and `map_window.npy`, the pixels of the
blocks whose points lie in it, cut from each scene by numpy.

Usage: python make_fixtures.py OUT_DIR
"""

import json
import sys
from pathlib import Path

import numpy as np

ROWS, COLS = 40, 30
LOOKS = (8, 2)  # azimuth (rows), range (columns): the `2x8` product
LLH_ROWS, LLH_COLS = ROWS // LOOKS[0], COLS // LOOKS[1]
LLH = "testsite_L090HH_01_BC_s1_2x8.llh"
BOX = ((-118.0035, -117.9985), (34.0012, 34.0031))


def llh_grid():
    """Latitude and longitude of every block: a grid rotated against north."""
    i, j = np.meshgrid(np.arange(LLH_ROWS), np.arange(LLH_COLS), indexing="ij")
    lat = 34.0 + 1e-3 * (0.9 * i + 0.2 * j) / 2
    lon = -118.0 + 1e-3 * (1.0 * j - 0.3 * i) / 2 - 0.0035
    return lat.astype("<f4"), lon.astype("<f4")


def annotation(name: str, date: str) -> str:
    return f"""; UAVSAR annotation file for {name} (test fixture)
; search for parameters/value rather than placement in file
UAVSAR Annotation File Version Number      (-)        = 3.0
Site Description                           (&)        = test site
Date of Acquisition                        (&)        = {date}
Center Wavelength                          (cm)       = 23.8403545
Number of Segments                         (-)        = 1
slc_1_1x1 Rows                             (pixels)   = {ROWS}        ; samples in along-track direction
slc_1_1x1 Columns                          (pixels)   = {COLS}.0      ; samples in cross-track direction
slc_1_1x1 Data Type                        (&)        = COMPLEX(Real*4,Real*4)
llh_1_2x8                                  (&)        = {LLH}
llh_1_2x8.set_rows                         (pixels)   = {LLH_ROWS}
llh_1_2x8.set_cols                         (pixels)   = {LLH_COLS}
"""


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20260429)
    lat, lon = llh_grid()
    llh = np.stack([lat, lon, np.full_like(lat, 120.0)], axis=-1).astype("<f4")
    llh.tofile(out / LLH)
    # The blocks whose points lie in the box, as pixel rows and columns.
    back = np.fromfile(out / LLH, dtype="<f4").reshape(LLH_ROWS, LLH_COLS, 3)
    (x0, x1), (y0, y1) = BOX
    inside = (back[..., 1] >= x0) & (back[..., 1] <= x1) & (back[..., 0] >= y0) & (back[..., 0] <= y1)
    ii, jj = np.nonzero(inside)
    assert len(ii) > 1 and len(set(ii)) > 1 and len(set(jj)) > 1, "the box must hold several blocks"
    r0, r1 = ii.min() * LOOKS[0], min((ii.max() + 1) * LOOKS[0], ROWS)
    c0, c1 = jj.min() * LOOKS[1], min((jj.max() + 1) * LOOKS[1], COLS)
    (out / "map_box.json").write_text(
        json.dumps({"box": [list(BOX[0]), list(BOX[1])], "window": [int(r0), int(r1), int(c0), int(c1)]})
    )
    map_windows = []
    windows, whole = [], []
    for k, date in enumerate(["12-May-2014", "14-May-2014", "19-May-2014"]):
        name = f"testsite_0{k}_L090HH_01_BC"
        scene = (rng.standard_normal((ROWS, COLS)) + 1j * rng.standard_normal((ROWS, COLS)))
        scene = (scene * (1 + k)).astype("<c8")
        scene.tofile(out / f"{name}_s1_1x1.slc")
        (out / f"{name}.ann").write_text(annotation(name, date))
        # What numpy reads back from the file, independently of the writer above.
        back = np.fromfile(out / f"{name}_s1_1x1.slc", dtype="<c8").reshape(ROWS, COLS)
        windows.append(back[5:21, 7:23])
        whole.append(back)
        map_windows.append(back[r0:r1, c0:c1])
    np.save(out / "window.npy", np.stack(windows))
    np.save(out / "scenes.npy", np.stack(whole))
    np.save(out / "map_window.npy", np.stack(map_windows))


if __name__ == "__main__":
    main(Path(sys.argv[1]))

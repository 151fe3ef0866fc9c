"""UAVSAR fixtures for tests/uavsar.rs, written with numpy alone (not by the tool).

Three coregistered scenes of 40 rows x 30 columns, each a `.slc` of little-endian complex64
values named as UAVSAR names them (`<name>_s1_1x1.slc`) with its annotation `<name>.ann` in
UAVSAR's `key (unit) = value ; comment` form, and `window.npy`: rows 5..21 and columns 7..23
of each scene as numpy reads them, an [N, H, W] complex64 stack, and `scenes.npy`, the whole
scenes as numpy reads them.

Usage: python make_fixtures.py OUT_DIR
"""

import sys
from pathlib import Path

import numpy as np

ROWS, COLS = 40, 30


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
"""


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20260429)
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
    np.save(out / "window.npy", np.stack(windows))
    np.save(out / "scenes.npy", np.stack(whole))


if __name__ == "__main__":
    main(Path(sys.argv[1]))

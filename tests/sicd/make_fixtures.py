"""SICD fixtures for tests/sicd.rs, written by sarpy (NGA's SICD reader and writer), not by
the tool.

- `scene_0{k}.nitf`, k = 0, 1, 2: three coregistered 40 x 30 SICD images of `RE16I_IM16I`
  pixels (a collection over time), and `window.npy`: rows 5..21 and columns 7..23 of each as
  sarpy reads them, an [N, H, W] complex64 stack.
- `float_0{k}.nitf`: the same scenes as `RE32F_IM32F`, and `float_window.npy` from them.
- `cal_0{k}.nitf`: the float scenes with a sigma-0 scale polynomial (`Radiometric/
  SigmaZeroSFPoly`, `SIGMA0_COEFS[i][j]` of `xrow^i ycol^j`), and `cal_sigma0.npy`: their
  whole images calibrated to sigma-0 amplitudes by numpy from SICD's definition.

Usage: python make_fixtures.py OUT_DIR
"""

import logging
import sys
from pathlib import Path

import numpy as np
from sarpy.io.complex.converter import open_complex
from sarpy.io.complex.sicd import SICDWriter
from sarpy.io.complex.sicd_elements.CollectionInfo import CollectionInfoType, RadarModeType
from sarpy.io.complex.sicd_elements.GeoData import GeoDataType, SCPType
from sarpy.io.complex.sicd_elements.Grid import DirParamType, GridType
from sarpy.io.complex.sicd_elements.ImageData import FullImageType, ImageDataType
from sarpy.io.complex.sicd_elements.ImageFormation import ImageFormationType
from sarpy.io.complex.sicd_elements.RadarCollection import ChanParametersType, RadarCollectionType
from sarpy.io.complex.sicd_elements.Radiometric import RadiometricType
from sarpy.io.complex.sicd_elements.blocks import Poly2DType
from sarpy.io.complex.sicd_elements.SICD import SICDType
from sarpy.io.complex.sicd_elements.Timeline import TimelineType

ROWS, COLS = 40, 30
ROW_SS, COL_SS = 0.5, 0.4
SIGMA0_COEFS = [[2.0, 0.01], [0.02, 0.001]]


def meta(pixel: str, day: int, sigma0=None) -> SICDType:
    return SICDType(
        Radiometric=None if sigma0 is None else RadiometricType(
            SigmaZeroSFPoly=Poly2DType(Coefs=sigma0)),
        ImageData=ImageDataType(NumRows=ROWS, NumCols=COLS, PixelType=pixel, FirstRow=0,
                                FirstCol=0, FullImage=FullImageType(NumRows=ROWS, NumCols=COLS),
                                SCPPixel=(ROWS // 2, COLS // 2)),
        CollectionInfo=CollectionInfoType(CollectorName="TESTSAT", CoreName=f"CORE{day:02d}",
                                          RadarMode=RadarModeType(ModeType="SPOTLIGHT"),
                                          Classification="UNCLASSIFIED"),
        Timeline=TimelineType(CollectStart=np.datetime64(f"2024-05-{day:02d}T10:00:00"),
                              CollectDuration=2.0),
        GeoData=GeoDataType(SCP=SCPType(LLH=[48.0, 11.0, 500.0])),
        Grid=GridType(ImagePlane="SLANT", Type="RGAZIM",
                      Row=DirParamType(SS=ROW_SS, ImpRespBW=2.2, Sgn=-1, KCtr=60.0, DeltaK1=-1.1,
                                       DeltaK2=1.1, ImpRespWid=0.45),
                      Col=DirParamType(SS=COL_SS, ImpRespBW=2.6, Sgn=-1, KCtr=0.0, DeltaK1=-1.3,
                                       DeltaK2=1.3, ImpRespWid=0.38)),
        RadarCollection=RadarCollectionType(
            TxPolarization="V", RcvChannels=[ChanParametersType(TxRcvPolarization="V:V", index=1)]),
        ImageFormation=ImageFormationType(TxRcvPolarizationProc="V:V"),
    )


def main(out: Path) -> None:
    logging.disable(logging.CRITICAL)  # sarpy's notes on the metadata a test leaves out
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20261129)
    read = {"scene": [], "float": [], "cal": []}
    for k in range(3):
        ints = rng.integers(-3000 * (k + 1), 3000 * (k + 1), (2, ROWS, COLS))
        z = (ints[0] + 1j * ints[1]).astype(np.complex64)
        sets = [("scene", "RE16I_IM16I", z, None), ("float", "RE32F_IM32F", z * 0.25, None),
                ("cal", "RE32F_IM32F", z * 0.25, SIGMA0_COEFS)]
        for name, pixel, data, sigma0 in sets:
            path = out / f"{name}_0{k}.nitf"
            with SICDWriter(str(path), meta(pixel, 1 + 12 * k, sigma0), check_existence=False) as w:
                w.write_chip(data)
            # What sarpy reads back from the file, independently of the writer above.
            back = open_complex(str(path))
            read[name].append(back[5:21, 7:23] if sigma0 is None else back[:, :])
    np.save(out / "window.npy", np.stack(read["scene"]).astype(np.complex64))
    np.save(out / "float_window.npy", np.stack(read["float"]).astype(np.complex64))
    # sigma-0 = SigmaZeroSFPoly(xrow, ycol) |pixel|^2, xrow = (row - SCPPixel.Row) Row.SS
    # (FirstRow 0), ycol likewise (SICD Vol. 1): amplitudes times the polynomial's root.
    x = (np.arange(ROWS) - ROWS // 2)[:, None] * ROW_SS
    y = (np.arange(COLS) - COLS // 2)[None, :] * COL_SS
    sf = sum(c * x**i * y**j for i, row in enumerate(SIGMA0_COEFS) for j, c in enumerate(row))
    np.save(out / "cal_sigma0.npy", np.stack(read["cal"]) * np.sqrt(sf))


if __name__ == "__main__":
    main(Path(sys.argv[1]))

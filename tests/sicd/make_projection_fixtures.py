"""SICD fixtures with full projection metadata for tests/sicd.rs, written by sarpy (NGA's SICD
reader and writer), and sarpy's own ground-to-image projections of points around them: the
oracle of the tool's SICD projection (`io::projection`) and of map-box windows.

A right-looking airborne pass (200 m/s north, 10 km up, 15 km west of a scene centre at 48 N,
11 E, 500 m) imaged four ways, one file each, 60 x 50 pixels:

- `proj_inca.nitf`: grid RGZERO, RMA/INCA (range-Doppler at zero Doppler, as Umbra and Capella
  deliver spotlight and stripmap images), `FirstRow`/`FirstCol` 0;
- `proj_pfa.nitf`: grid RGAZIM, PFA (a polar angle of time, a spatial frequency scale factor);
- `proj_rgazcomp.nitf`: grid RGAZIM, RGAZCOMP;
- `proj_plane.nitf`: grid PLANE on the ground.

`proj_points.json`: for each file, latitude/longitude/height points on and around the image and
the (row, col) sarpy's `ground_to_image_geo` gives them, with its residual (m). A second INCA
image with other pixels, `proj_inca_b.nitf`, makes a coregistered stack with the first, and
`map_window.npy` holds both images' pixels in the window that covers the box
`MAP_BOX` (longitude, latitude) at the scene centre's height: its edges mapped by sarpy at 17
points each, pixel centres moved to corners (+0.5), rounded outwards, read by sarpy.

Usage: python make_projection_fixtures.py OUT_DIR
"""

import json
import logging
import sys
from pathlib import Path

import numpy as np
from sarpy.geometry.geocoords import ecf_to_geodetic, geodetic_to_ecf, wgs_84_norm
from sarpy.geometry.point_projection import ground_to_image_geo
from sarpy.io.complex.converter import open_complex
from sarpy.io.complex.sicd import SICDWriter
from sarpy.io.complex.sicd_elements.blocks import Poly1DType, Poly2DType, XYZPolyType, XYZType
from sarpy.io.complex.sicd_elements.CollectionInfo import CollectionInfoType, RadarModeType
from sarpy.io.complex.sicd_elements.GeoData import GeoDataType, SCPType
from sarpy.io.complex.sicd_elements.Grid import DirParamType, GridType
from sarpy.io.complex.sicd_elements.ImageData import FullImageType, ImageDataType
from sarpy.io.complex.sicd_elements.ImageFormation import ImageFormationType
from sarpy.io.complex.sicd_elements.PFA import PFAType
from sarpy.io.complex.sicd_elements.Position import PositionType
from sarpy.io.complex.sicd_elements.RgAzComp import RgAzCompType
from sarpy.io.complex.sicd_elements.RMA import INCAType, RMAType
from sarpy.io.complex.sicd_elements.SCPCOA import SCPCOAType
from sarpy.io.complex.sicd_elements.SICD import SICDType
from sarpy.io.complex.sicd_elements.Timeline import TimelineType

ROWS, COLS = 60, 50
ROW_SS, COL_SS = 0.5, 0.4
SCP_LLH = [48.0, 11.0, 500.0]
SPEED = 200.0
# (lon0, lon1), (lat0, lat1): a box inside the INCA image whose lowest column centre (8.82)
# falls in another pixel when centres are taken for corners (a test of the half-pixel shift).
MAP_BOX = ((11.0 - 0.00012, 11.0 + 0.00005), (48.0 - 0.0000582, 48.0 + 0.00008))


def unit(v):
    return v / np.linalg.norm(v)


def geometry():
    scp = geodetic_to_ecf(SCP_LLH)
    up = wgs_84_norm(scp)
    north = unit(np.cross(np.cross(up, [0.0, 0.0, 1.0]), up))
    east = np.cross(north, up)
    v = SPEED * north
    p0 = scp + 10_000.0 * up - 15_000.0 * east - SPEED * north
    return scp, up, north, east, v, p0


def meta(kind: str) -> SICDType:
    scp, up, north, east, v, p0 = geometry()
    t_ca = float(np.dot(scp - p0, v) / np.dot(v, v))
    arp = lambda t: p0 + t * v  # noqa: E731
    r_ca = float(np.linalg.norm(scp - arp(t_ca)))
    u_range = unit(scp - arp(t_ca))
    if kind == "plane":
        u_row, u_col = unit(np.cross(north, up)), north  # ground range (east), along track
    else:
        u_row, u_col = u_range, unit(v)
    zero_doppler = Poly2DType(Coefs=[[t_ca, 1.0 / SPEED]])
    extra = {}
    grid_type, algo, time_coa = "RGZERO", "RMA", zero_doppler
    if kind == "inca":
        extra["RMA"] = RMAType(RMAlgoType="OMEGA_K", ImageType="INCA", INCA=INCAType(
            TimeCAPoly=Poly1DType(Coefs=[t_ca, 1.0 / SPEED]), R_CA_SCP=r_ca, FreqZero=9.6e9,
            DRateSFPoly=Poly2DType(Coefs=[[1.0, 1e-7], [2e-6, 0.0]])))
    elif kind == "pfa":
        grid_type, algo, time_coa = "RGAZIM", "PFA", Poly2DType(Coefs=[[t_ca]])
        extra["PFA"] = PFAType(
            FPN=XYZType.from_array(up), IPN=XYZType.from_array(unit(np.cross(u_row, u_col))),
            PolarAngRefTime=t_ca, PolarAngPoly=Poly1DType(Coefs=[0.0, -SPEED / r_ca, 1e-5]),
            SpatialFreqSFPoly=Poly1DType(Coefs=[1.0, 0.0, 0.02]), Krg1=380.0, Krg2=420.0,
            Kaz1=-20.0, Kaz2=20.0)
    elif kind == "rgazcomp":
        grid_type, algo, time_coa = "RGAZIM", "RGAZCOMP", Poly2DType(Coefs=[[t_ca]])
        extra["RgAzComp"] = RgAzCompType(AzSF=1.0 / r_ca, KazPoly=Poly1DType(Coefs=[0.0]))
    else:
        grid_type, algo = "PLANE", "OTHER"
    row = DirParamType(SS=ROW_SS, ImpRespBW=2.2, Sgn=-1, KCtr=60.0, DeltaK1=-1.1, DeltaK2=1.1,
                       ImpRespWid=0.45, UVectECF=XYZType.from_array(u_row))
    col = DirParamType(SS=COL_SS, ImpRespBW=2.6, Sgn=-1, KCtr=0.0, DeltaK1=-1.3, DeltaK2=1.3,
                       ImpRespWid=0.38, UVectECF=XYZType.from_array(u_col))
    return SICDType(
        ImageData=ImageDataType(NumRows=ROWS, NumCols=COLS, PixelType="RE32F_IM32F", FirstRow=0,
                                FirstCol=0, FullImage=FullImageType(NumRows=ROWS, NumCols=COLS),
                                SCPPixel=(ROWS // 2, COLS // 2)),
        CollectionInfo=CollectionInfoType(CollectorName="TESTPLANE", CoreName=f"PROJ_{kind}",
                                          RadarMode=RadarModeType(ModeType="SPOTLIGHT"),
                                          Classification="UNCLASSIFIED"),
        Timeline=TimelineType(CollectStart=np.datetime64("2024-05-01T10:00:00"),
                              CollectDuration=2.0 * t_ca),
        GeoData=GeoDataType(SCP=SCPType(ECF=scp, LLH=SCP_LLH)),
        Position=PositionType(ARPPoly=XYZPolyType(
            X=Poly1DType(Coefs=[p0[0], v[0]]), Y=Poly1DType(Coefs=[p0[1], v[1]]),
            Z=Poly1DType(Coefs=[p0[2], v[2]]))),
        Grid=GridType(ImagePlane="GROUND" if kind == "plane" else "SLANT", Type=grid_type,
                      TimeCOAPoly=time_coa, Row=row, Col=col),
        SCPCOA=SCPCOAType(SCPTime=t_ca, ARPPos=XYZType.from_array(arp(t_ca)),
                          ARPVel=XYZType.from_array(v), ARPAcc=XYZType.from_array([0.0] * 3),
                          SideOfTrack="R"),
        ImageFormation=ImageFormationType(ImageFormAlgo=algo, TxRcvPolarizationProc="V:V"),
        **extra,
    )


def map_window(sicd, box):
    (x0, x1), (y0, y1) = box
    at = lambda t, a, b: a + (b - a) * t / 16  # noqa: E731
    pts = []
    for t in range(17):
        pts += [(at(t, x0, x1), y0), (at(t, x0, x1), y1), (x0, at(t, y0, y1)),
                (x1, at(t, y0, y1))]
    coords = np.array([[lat, lon, SCP_LLH[2]] for lon, lat in pts])
    ip, resid, _ = ground_to_image_geo(coords, sicd, tolerance=1e-9, max_iterations=50)
    assert np.all(resid < 1e-6), resid.max()
    corners = ip + 0.5

    def snap(v):
        return np.where(np.abs(v - np.round(v)) < 1e-6, np.round(v), v)

    lo = np.floor(snap(corners.min(axis=0))).astype(int)
    hi = np.ceil(snap(corners.max(axis=0))).astype(int)
    return lo, hi


def main(out: Path) -> None:
    logging.disable(logging.CRITICAL)  # sarpy's notes on the metadata a test leaves out
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20261130)
    points = {}
    for kind in ["inca", "pfa", "rgazcomp", "plane", "inca_b"]:
        z = (rng.normal(size=(ROWS, COLS)) + 1j * rng.normal(size=(ROWS, COLS))).astype(
            np.complex64)
        path = out / f"proj_{kind}.nitf"
        with SICDWriter(str(path), meta(kind.removesuffix("_b")), check_existence=False) as w:
            w.write_chip(z)
        if kind == "inca_b":
            continue
        sicd = open_complex(str(path)).sicd_meta  # the projection of what the file holds
        assert sicd.can_project_coordinates()
        corners = sicd.project_image_to_ground(
            np.array([[0, 0], [0, COLS - 1], [ROWS - 1, 0], [ROWS - 1, COLS - 1]]),
            projection_type="HAE")
        llh = ecf_to_geodetic(corners)
        lat = np.linspace(llh[:, 0].min() - 1e-4, llh[:, 0].max() + 1e-4, 6)
        lon = np.linspace(llh[:, 1].min() - 1e-4, llh[:, 1].max() + 1e-4, 5)
        coords = np.array([[a, o, h] for a in lat for o in lon for h in (SCP_LLH[2], 620.0)])
        ip, resid, _ = ground_to_image_geo(coords, sicd, tolerance=1e-9, max_iterations=50)
        assert np.all(resid < 1e-6), (kind, resid.max())
        points[kind] = {"llh": coords.tolist(), "pixel": ip.tolist(), "residual": resid.tolist()}
    (out / "proj_points.json").write_text(json.dumps(points))
    a = open_complex(str(out / "proj_inca.nitf"))
    b = open_complex(str(out / "proj_inca_b.nitf"))
    (r0, c0), (r1, c1) = map_window(a.sicd_meta, MAP_BOX)
    assert 0 <= r0 < r1 <= ROWS and 0 <= c0 < c1 <= COLS, (r0, r1, c0, c1)
    np.save(out / "map_window.npy", np.stack([a[r0:r1, c0:c1], b[r0:r1, c0:c1]]))
    (out / "map_box.json").write_text(json.dumps(
        {"box": MAP_BOX, "window": [int(r0), int(r1), int(c0), int(c1)]}))


if __name__ == "__main__":
    main(Path(sys.argv[1]))

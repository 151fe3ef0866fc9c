"""isar_clutter: multiscale statistics and synthesis of ISAR clutter on numpy arrays.

The analysis, the fit and the generation of the isar-clutter command line, in process:

    import numpy as np, isar_clutter as ic
    maps = ic.analyse(stack, levels=3)          # stack: [N, H, W] complex or real
    model = ic.fit(stack, method="method2")     # or ic.Model.load("models/m2")
    x = model.generate(1000, seed=7)            # complex64 [1000, H, W]
    model.save("models/m2")                     # a model folder the command line reads

``isar_clutter.load`` reads radar scenes in the field's formats into the same arrays (UAVSAR
``.slc`` stacks, complex GeoTIFF scenes, SICD images, HDF5 stacks and scenes; checked as the command line's dataset kinds check them).

Sample ``i`` of a seed is byte for byte the one ``isar-clutter generate --seed`` writes,
whether drawn alone, in blocks or by the command line. ``isar_clutter.torch.ClutterDataset``
streams unlimited clutter into a PyTorch DataLoader (importing ``isar_clutter`` does not need
torch).
"""

import os
from pathlib import Path
from typing import Optional, Sequence, Tuple, Union

from ._native import Model, __version__, analyse, epoch_seed, fit, load_geotiff, load_sicd, load_uavsar
from .hdf5 import load_hdf5

__all__ = ["Model", "__version__", "analyse", "epoch_seed", "fit", "load"]

PathArg = Union[str, "os.PathLike[str]"]

#: The file name suffixes ``load`` reads as HDF5.
HDF5_SUFFIXES = {".h5", ".hdf5", ".he5"}


def _paths(p: Union[PathArg, Sequence[PathArg], None]) -> list:
    if p is None:
        return []
    if isinstance(p, (str, os.PathLike)):
        return [os.fspath(p)]
    return [os.fspath(x) for x in p]


def load(
    path: Union[PathArg, Sequence[PathArg]],
    *,
    annotation: Union[PathArg, Sequence[PathArg], None] = None,
    window: Optional[Tuple[int, int, int, int]] = None,
    calibration: Optional[str] = None,
    dataset: Optional[str] = None,
    imag: Optional[str] = None,
    layout: str = "nhw",
    map_box: Optional[Tuple[Tuple[float, float], Tuple[float, float]]] = None,
):
    """A stack of radar images as a numpy array ``[N, H, W]``, ready for ``analyse`` and ``fit``.

    ``path``: one file or a list of coregistered ones. Read by their kind:

    - UAVSAR single-look complex scenes (``.slc``, little-endian complex64) with their
      annotation (``annotation``: one for all, one per scene, or none: each scene's own,
      ``<name>.ann`` beside ``<name>_s<k>_1x1.slc``); every scene is one sample, read in
      ``window`` ``(row, col, rows, cols)`` (default: the whole scene), or in the pixels
      covering ``map_box`` ``((lon0, lon1), (lat0, lat1))`` through the flight line's ``.llh``
      grid (a latitude and longitude every block of looks). complex64.
    - Complex GeoTIFF scenes (``.tif``, ``.tiff``: Sentinel-1 SLC measurement files, Capella
      SLCs; complex int16 / int32 / float32 / float64, or two int16 / float32 samples a pixel;
      strips or tiles, uncompressed or deflate); every scene is one sample, read in
      ``window`` as above, or in the pixels covering ``map_box`` ``((x0, x1), (y0, y1))``
      of the files' map coordinates (their affine transform, or their ground control points
      as GDAL fits them: longitude and latitude for Sentinel-1). complex64; ``calibration``
      (``"sigma0"``, ``"beta0"``, ``"gamma0"``) divides each value of a Sentinel-1
      measurement by its SAFE product's calibration table there (``annotation/calibration/
      calibration-<name>.xml``), so that ``|x|**2`` is that quantity.
    - SICD images (``.nitf``, ``.ntf``: NITF 2.1 with SICD XML, Umbra's and Capella's
      single-look complex deliveries; ``RE32F_IM32F``, ``RE16I_IM16I``, ``AMP8I_PHS8I``);
      every image is one sample, read in ``window`` as above, or in the pixels covering
      ``map_box`` ``((lon0, lon1), (lat0, lat1))`` (degrees) through SICD's own image
      projection at the scene centre's height. complex64; ``calibration``
      (``"sigma0"``, ``"beta0"``, ``"gamma0"``, ``"rcs"``) multiplies each pixel by the root
      of the file's ``Radiometric`` scale polynomial there, so that ``|x|**2`` is that
      quantity.
    - HDF5 files (``.h5``, ``.hdf5``, ``.he5``: h5py's stacks, NISAR RSLC and OPERA CSLC
      frames), read with h5py (``pip install h5py``): the dataset at ``dataset`` (its path
      in the file), complex compounds, float pairs, or real numbers with the imaginary
      parts in the dataset ``imag``; a stack ``[N, H, W]`` (``layout="hwn"``: ``[H, W, N]``)
      or a single scene ``[H, W]`` read in ``window`` (giving ``[1, rows, cols]``), or in
      ``map_box`` through the coordinate vectors beside it (OPERA's ``x_coordinates`` and
      ``y_coordinates``, NISAR's ``xCoordinates`` and ``yCoordinates``; else a NISAR
      RSLC's geolocation grid at its terrain height, longitude and latitude); a scene's
      ``calibration`` (``"beta0"``, ``"sigma0"``, ``"gamma0"``) divides each value by the
      NISAR product's table of it at its pixel (RSLC, GSLC), or, for ``beta0``, multiplies
      it by the root of ICEYE's ``calibration_factor``.
      complex64 where the stored numbers fit a float32, else complex128.

    A bad file raises ``ValueError`` naming the field (``slc[i]``, ``annotation``, ``path[i]``,
    ``window``), the file and the format's field at fault (a TIFF tag, a NITF field, a SICD XML
    element), as ``kind: uavsar``, ``kind: geotiff`` and ``kind: sicd`` in a spec do.
    """
    paths = _paths(path)
    kinds = {Path(p).suffix.lower() for p in paths}
    if kinds and kinds <= HDF5_SUFFIXES:
        if len(paths) != 1 or annotation is not None:
            raise ValueError(
                "HDF5: give one file, its dataset= (and imag=, layout=, window=, calibration=)"
            )
        return load_hdf5(paths[0], dataset, imag, layout, window, map_box, calibration)
    if dataset is not None or imag is not None:
        raise ValueError("dataset= and imag= name datasets of an HDF5 file (.h5, .hdf5, .he5)")
    if calibration is not None and not (kinds and kinds <= {".nitf", ".ntf", ".tif", ".tiff"}):
        raise ValueError(
            "calibration reads SICD's scale factors (.nitf/.ntf files), Sentinel-1's "
            "calibration annotations (.tiff measurements in their SAFE product) and HDF5 "
            "products' (NISAR's tables, ICEYE's factor)"
        )
    if kinds == {".slc"}:
        return load_uavsar(paths, _paths(annotation), window, map_box)
    if map_box is not None and not (kinds and kinds <= {".tif", ".tiff", ".nitf", ".ntf"}):
        raise ValueError(
            "map_box: map coordinates are read from GeoTIFF scenes (.tif, .tiff), SICD "
            "images (.nitf, .ntf) and HDF5 scenes (.h5, .hdf5, .he5)"
        )
    if kinds and kinds <= {".tif", ".tiff"} and annotation is None:
        return load_geotiff(paths, window, map_box, calibration)
    if kinds and kinds <= {".nitf", ".ntf"} and annotation is None:
        return load_sicd(paths, window, calibration, map_box)
    raise ValueError(
        "load reads UAVSAR .slc files (with an annotation), GeoTIFF .tif/.tiff, SICD "
        f".nitf/.ntf and HDF5 .h5/.hdf5/.he5 files; "
        f"{sorted(kinds) or 'no path'} given "
        "(other formats: the command line's dataset kinds, docs/spec.md)"
    )

"""Type hints of the extension module (see the package's docstring)."""

from os import PathLike
from typing import Dict, Optional, Sequence, Tuple, Union

import numpy as np

__version__: str

def analyse(
    stack: np.ndarray, levels: int = 3, layout: str = "nhw"
) -> Dict[str, Union[np.ndarray, int]]:
    """The multiscale maps of ``stack`` ([N, H, W]; ``layout="hwn"`` for [H, W, N]) of complex64,
    complex128, float32 or float64: ``mean`` (complex128 [H, W]), ``variance``,
    ``level{L}_correlation_{H,V,D}``, ``level{L}_covariance_{H,V,D}`` (float64) and ``samples``,
    the names and values of a run's ``maps/<job>/`` files. Raises TypeError for another array
    and ValueError for NaN or infinite values, fewer than 2 samples, or too many levels."""

def fit(
    stack: np.ndarray,
    method: str = "method2",
    half_width: int = 8,
    levels: int = 3,
    negative_signs: str = "multiscale",
    layout: str = "nhw",
    source: str = "numpy array",
) -> "Model":
    """A synthesis model fitted to ``stack`` as ``isar-clutter fit`` fits it: ``method`` one of
    method1, method2, full_covariance, uncorrelated, fourth_order."""

def epoch_seed(seed: int, epoch: int) -> int:
    """The seed of epoch ``epoch`` of a stream seeded by ``seed`` (``seed`` for epoch 0)."""

def load_uavsar(
    slcs: Sequence[Union[str, PathLike]],
    annotations: Sequence[Union[str, PathLike]],
    window: Optional[Tuple[int, int, int, int]] = None,
    map_box: Optional[Tuple[Tuple[float, float], Tuple[float, float]]] = None,
) -> np.ndarray:
    """The window ``(row, col, rows, cols)`` (or the pixels covering ``map_box``) of every
    UAVSAR scene as complex64 [N, H, W]."""

def load_geotiff(
    paths: Sequence[Union[str, PathLike]],
    window: Optional[Tuple[int, int, int, int]] = None,
    map_box: Optional[Tuple[Tuple[float, float], Tuple[float, float]]] = None,
    calibration: Optional[str] = None,
) -> np.ndarray:
    """The window ``(row, col, rows, cols)`` (or the pixels covering ``map_box`` ``((x0, x1),
    (y0, y1))`` in map coordinates) of every complex GeoTIFF scene as complex64 [N, H, W],
    calibrated to ``calibration`` by each Sentinel-1 measurement's SAFE annotation."""

def load_sicd(
    paths: Sequence[Union[str, PathLike]],
    window: Optional[Tuple[int, int, int, int]] = None,
    calibration: Optional[str] = None,
) -> np.ndarray:
    """The window ``(row, col, rows, cols)`` of every SICD image as complex64 [N, H, W],
    calibrated to ``calibration`` (sigma0, beta0, gamma0, rcs) where given."""

class Model:
    """A synthesis model: from ``fit``, or ``Model.load`` of a model folder."""

    @staticmethod
    def load(path: Union[str, PathLike]) -> "Model":
        """The model folder ``path`` (written by ``Model.save`` or ``isar-clutter fit``)."""
    def save(self, path: Union[str, PathLike]) -> None:
        """Writes the model folder ``path`` as ``isar-clutter fit --out`` does."""
    @property
    def method(self) -> str: ...
    @property
    def shape(self) -> Tuple[int, int]: ...
    @property
    def sample_format(self) -> int: ...
    @property
    def info_json(self) -> str: ...
    def generate(
        self, n: int, seed: int, start: int = 0, threads: Optional[int] = None
    ) -> np.ndarray:
        """Samples ``start .. start + n`` of the generation seeded by ``seed`` as complex64
        [n, H, W], byte for byte those of ``isar-clutter generate --seed``; the GIL is released
        while they are computed on ``threads`` threads (default: all cores)."""
    def __reduce__(self) -> tuple:
        """Pickles the model as its model folder's files (DataLoader workers under ``spawn``)."""

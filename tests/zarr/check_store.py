"""Opens a run's maps.zarr with xarray (lazily, through zarr-python) and checks every array
against the run's .npy maps (maps/<job>/<name>.npy), value for value; a job without a map
must be all NaN. Prints one line: the arrays, jobs and values compared.

Usage: python check_store.py RUN_DIR [NPY_RUN_DIR]   (the .npy maps from NPY_RUN_DIR, default
RUN_DIR)
"""

import sys
import warnings
from pathlib import Path

import numpy as np
import xarray as xr
import zarr

warnings.filterwarnings("ignore", category=DeprecationWarning)


def main(run: Path, npy_run: Path) -> None:
    group = zarr.open_group(run / "maps.zarr", mode="r")
    jobs = group.attrs["jobs"]
    ds = xr.open_zarr(run / "maps.zarr", consolidated=False, zarr_format=3)
    arrays = values = 0
    for name, var in ds.data_vars.items():
        assert var.dims[0] == "job" and var.shape[0] == len(jobs), (name, var.dims, var.shape)
        arrays += 1
        whole = var.values  # read once, lazily until here
        for j, job in enumerate(jobs):
            got = whole[j]
            # A second size of a map name is the array `<name>@<rows>x<cols>`.
            base = name.split("@")[0]
            path = npy_run / "maps" / job / f"{base}.npy"
            want = np.load(path) if path.is_file() else None
            if want is not None and want.shape == got.shape:
                assert got.shape == want.shape and np.array_equal(got, want, equal_nan=True), \
                    (name, job)
                values += want.size
            else:
                # Not this job's map, or its map of another size (in the other array).
                assert np.isnan(got).all(), (name, job)
    print(f"{arrays} arrays, {len(jobs)} jobs, {values} values equal")


if __name__ == "__main__":
    run = Path(sys.argv[1])
    main(run, Path(sys.argv[2]) if len(sys.argv) > 2 else run)

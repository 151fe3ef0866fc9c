"""``isar_clutter.load`` reads UAVSAR scenes written by numpy (not by the tool) as numpy reads
them, and refuses bad files naming the field and the file."""

import numpy as np
import pytest

import isar_clutter as ic

ROWS, COLS = 12, 10


def scenes(tmp_path, n=3):
    """``n`` scenes named as UAVSAR names them, each with its annotation; numpy's reading."""
    rng = np.random.default_rng(4)
    paths, read = [], []
    for k in range(n):
        name = f"site_0{k}_L090HH_01_BC"
        x = (rng.standard_normal((ROWS, COLS)) + 1j * rng.standard_normal((ROWS, COLS))).astype("<c8")
        x.tofile(tmp_path / f"{name}_s1_1x1.slc")
        (tmp_path / f"{name}.ann").write_text(
            f"; test annotation\nslc_1_1x1 Rows (pixels) = {ROWS} ; along track\n"
            f"slc_1_1x1 Columns (pixels) = {COLS}\n"
        )
        paths.append(tmp_path / f"{name}_s1_1x1.slc")
        read.append(np.fromfile(paths[-1], dtype="<c8").reshape(ROWS, COLS))
    return paths, np.stack(read)


def test_a_uavsar_stack_is_read_as_numpy_reads_it(tmp_path):
    paths, want = scenes(tmp_path)
    x = ic.load(paths)
    assert x.dtype == np.complex64 and x.shape == (3, ROWS, COLS)
    np.testing.assert_array_equal(x, want)
    w = ic.load([str(p) for p in paths], window=(2, 3, 6, 5))
    np.testing.assert_array_equal(w, want[:, 2:8, 3:8])
    one = ic.load(paths[1], annotation=tmp_path / "site_01_L090HH_01_BC.ann")
    np.testing.assert_array_equal(one, want[1:2])
    assert ic.analyse(w, levels=1)["samples"] == 3


def test_bad_uavsar_files_are_refused_naming_the_field_and_the_file(tmp_path):
    paths, _ = scenes(tmp_path)
    data = paths[2].read_bytes()
    paths[2].write_bytes(data[:-8])
    with pytest.raises(ValueError, match=r"slc\[2\]: .*site_02_L090HH_01_BC_s1_1x1.slc holds 952 bytes"):
        ic.load(paths)
    paths[2].write_bytes(data)
    with pytest.raises(ValueError, match=r"window: rows 10\.\.16"):
        ic.load(paths, window=(10, 0, 6, 5))
    (tmp_path / "bad.ann").write_text("slc_1_1x1 Rows (pixels) = 12\n")
    with pytest.raises(ValueError, match=r"annotation: .*bad.ann: field `slc_1_1x1 Columns` is missing"):
        ic.load(paths, annotation=tmp_path / "bad.ann")
    with pytest.raises(ValueError, match="load reads UAVSAR .slc files"):
        ic.load(tmp_path / "x.tif")

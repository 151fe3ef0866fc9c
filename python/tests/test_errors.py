"""Bad input is a Python exception naming the argument, never a crash; no memory grows over
many calls."""

import resource
import shutil

import numpy as np
import pytest

import isar_clutter as ic
from conftest import clutter


def test_a_stack_of_the_wrong_kind_is_refused_naming_it():
    with pytest.raises(TypeError, match="stack must be a numpy array, not list"):
        ic.analyse([[[1.0]]])
    with pytest.raises(TypeError, match="stack must have 3 dimensions"):
        ic.analyse(np.zeros((4, 4), np.complex64))
    with pytest.raises(TypeError, match="stack must be complex64, complex128, float32 or float64, not int32"):
        ic.fit(np.zeros((4, 4, 4), np.int32))
    bad = clutter(n=10, h=8, w=8)
    bad[3, 2, 1] = np.nan
    with pytest.raises(ValueError, match=r"NaN or infinite value at index \[3, 2, 1\]"):
        ic.fit(bad)
    with pytest.raises(ValueError, match="at least 2 samples"):
        ic.analyse(clutter(n=1, h=8, w=8))
    with pytest.raises(ValueError, match="stack: "):
        ic.analyse(clutter(n=4, h=4, w=4), levels=5)
    with pytest.raises(ValueError, match="layout"):
        ic.analyse(clutter(n=4, h=8, w=8), layout="whn")
    with pytest.raises(ValueError, match="method: unknown method"):
        ic.fit(clutter(n=4, h=8, w=8), method="method3")


def test_layouts_and_element_types_agree():
    x = clutter(n=12, h=8, w=8, dtype=np.complex128)
    a = ic.analyse(x, levels=2)
    b = ic.analyse(np.ascontiguousarray(np.transpose(x, (1, 2, 0))), levels=2, layout="hwn")
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    r = ic.analyse(x.real.copy(), levels=1)
    assert np.all(r["mean"].imag == 0)
    # A strided view is read as it is.
    np.testing.assert_array_equal(
        ic.analyse(x[::2], levels=1)["variance"], ic.analyse(x[::2].copy(), levels=1)["variance"]
    )


def test_bad_generation_arguments_and_a_damaged_model_folder(tmp_path):
    model = ic.fit(clutter(n=20, h=8, w=8), method="method1")
    with pytest.raises(ValueError, match="n must be 0 or more, not -1"):
        model.generate(-1, 1)
    with pytest.raises(ValueError, match="start must be 0 or more"):
        model.generate(1, 1, start=-3)
    with pytest.raises(MemoryError, match=r"n = 1000000000000"):
        model.generate(10**12, 1)
    with pytest.raises(ValueError, match="threads must be at least 1"):
        model.generate(1, 1, threads=0)
    assert model.generate(0, 1).shape == (0, 8, 8)
    model.save(tmp_path / "m")
    with pytest.raises(OSError, match="is not empty and is not a model folder"):
        (tmp_path / "other").mkdir()
        (tmp_path / "other" / "notes.txt").write_text("mine")
        model.save(tmp_path / "other")
    for f in (tmp_path / "m").iterdir():
        if f.suffix == ".npy":
            f.write_bytes(f.read_bytes()[:40])
            break
    with pytest.raises(OSError):
        ic.Model.load(tmp_path / "m")
    shutil.rmtree(tmp_path / "m")
    with pytest.raises(OSError):
        ic.Model.load(tmp_path / "m")


def test_no_memory_grows_over_a_thousand_calls():
    x = clutter(n=16, h=16, w=16)
    model = ic.fit(x, method="method2")

    def rss_kb():
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * resource.getpagesize() // 1024

    for _ in range(50):
        model.generate(8, 1)
        ic.analyse(x, levels=2)
    before = rss_kb()
    for i in range(1000):
        model.generate(8, i)
        ic.analyse(x, levels=2)
    grown = rss_kb() - before
    # 1,000 calls allocate about 1,000 x (8 x 16 x 16 x 8 B + the maps) = 30 MB in all; a
    # leak of either would keep most of it.
    assert grown < 8 * 1024, f"resident memory grew by {grown} kB"


def test_importing_the_package_needs_no_torch():
    import subprocess
    import sys

    code = "import sys, isar_clutter; assert 'torch' not in sys.modules, 'torch was imported'"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr


ABSURD = [
    # (what the child runs, the exception it must print)
    ("ic.fit(x, method='method1', half_width=10**9)", "MemoryError: fitting method1 to numpy array: method1 with half_width 1000000000"),
    ("ic.fit(x, method='method2', half_width=10**9)", "MemoryError: fitting method2 to numpy array: method2 with half_width 1000000000"),
    ("ic.fit(x, method='method1').generate(2**62, 1)", "MemoryError: n = 4611686018427387904"),
    ("ic.fit(x, method='method1').generate(-1, 1)", "ValueError: n must be 0 or more"),
    ("ic.analyse(x, levels=10**9)", "ValueError: stack: "),
    ("ic.fit(x, method='method2', levels=10**9)", "ValueError"),
    ("ic.fit(x, method='method1').generate(3, 1, threads=100000).shape", "ResourceWarning: threads 100000 is more than"),
]


@pytest.mark.parametrize("call,says", ABSURD)
def test_absurd_arguments_raise_and_the_interpreter_survives(call, says):
    # In a child interpreter: an abort (SIGABRT) there fails this test instead of ending pytest.
    import subprocess
    import sys
    code = ("import warnings, numpy as np, isar_clutter as ic\n"
            "warnings.simplefilter('always')\n"
            "r = np.random.default_rng(0)\n"
            "x = (r.standard_normal((20, 8, 8)) + 1j * r.standard_normal((20, 8, 8))).astype(np.complex64)\n"
            "try:\n"
            f"    print({call})\n"
            "except Exception as e:\n"
            "    print(f'{type(e).__name__}: {e}')\n"
            "print('survived')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    both = out.stdout + out.stderr
    assert out.returncode == 0, f"the interpreter died ({out.returncode}): {both[-2000:]}"
    assert says in both and "survived" in out.stdout, both[-2000:]

"""Compiling the kernels in this process: one entry point for both frame dtypes, the cache's
index read to tell whether a launch would compile, and no other process started."""

import os
import subprocess
import sys

import numpy as np
import pytest

from radiosim.kernels import compiling


def test_both_frame_dtypes_launch_one_compiled_kernel():
    # float32 and float64 frames go through one entry point and one signature; a float32
    # frame gives the same bits as its float64 copy (the kernel widens each sample, exactly).
    from radiosim.kernels import SignalTable, accumulate, pixel_mean
    from radiosim.kernels.rows import ACCUMULATE_KERNELS, accumulate_kernel
    from radiosim.radiometry import BandRadianceTable

    assert set(ACCUMULATE_KERNELS) == {"float32", "float64"}
    assert all(k is accumulate_kernel for k in ACCUMULATE_KERNELS.values())
    rows, cols = compiling._tiny_axis(4), compiling._tiny_axis(6)
    table = SignalTable(BandRadianceTable(temperature_range=(200.0, 800.0), per_octave=16),
                        grey=0.9)
    rng = np.random.default_rng(11)
    frame = (300.0 + 400.0 * rng.random((rows.extent, cols.extent))).astype(np.float32)
    sums, signatures = {}, []
    for dtype in (np.float64, np.float32):
        block = frame.astype(dtype)
        shape = (rows.n_pixels, cols.n_pixels)
        reference = pixel_mean(block, rows, cols)
        dev, sq, signal, tmax = (np.zeros(shape), np.zeros(shape), np.zeros(shape),
                                 np.full(shape, -np.inf))
        accumulate(block, rows, cols, 0.5, reference, dev, sq, tmax, signal, table)
        sums[dtype] = np.stack([reference, dev, sq, signal, tmax])
        signatures.append(len(accumulate_kernel.signatures))
    assert sums[np.float32].tobytes() == sums[np.float64].tobytes()
    assert signatures[1] == signatures[0]  # float32 frames compiled nothing more


def test_float32_frames_take_the_sub_band_kernel_widened():
    # One compiled variant (float64 frames): float32 frames give the same sums as their
    # float64 copy (the widening is exact) and as the numpy reference, within its tolerance.
    from radiosim.kernels.bands import band_kernel, launch_bands
    from radiosim.kernels.reference import accumulate_bands_reference
    from radiosim.kernels.table import SignalTable
    from radiosim.radiometry import BandRadianceTable

    table = SignalTable(BandRadianceTable(temperature_range=(200.0, 800.0), per_octave=16),
                        grey=0.9)
    rng = np.random.default_rng(5)
    frames = (300.0 + 400.0 * rng.random((3, 7, 11))).astype(np.float32)
    weights = np.array([0.2, 0.5, 0.3])
    sums = {}
    for dtype in (np.float32, np.float64):
        out = np.zeros((2, 7, 11))
        status, rows = launch_bands(frames.astype(dtype), weights, [table, table], out)
        assert status == 0 and rows.size == 0
        sums[dtype] = out
    assert np.array_equal(sums[np.float32], sums[np.float64])
    reference = np.zeros((2, 7, 11))
    accumulate_bands_reference(frames, weights, [table, table], reference)
    np.testing.assert_allclose(sums[np.float32], reference, rtol=1e-12)
    assert len(band_kernel.signatures) == 1


def test_after_warmup_of_a_dtype_no_launch_of_it_would_compile():
    # compile_pending reads numba's index: once float64's variants are compiled (or loaded)
    # here, a launch on float64 frames would not compile; an unknown frame dtype always would.
    compiling.warmup(frame_dtypes=("float64",), bands=False)
    assert not compiling.compile_pending(("float64",))
    assert compiling.compile_pending(("int16",))


def _children(pid: int) -> list[str]:
    """The processes whose parent is ``pid`` (Linux's /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as stat:
                    fields = stat.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[1] == str(pid):
                found.append(entry)
    return found


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads Linux's /proc")
def test_warmup_and_a_measurement_start_no_other_process(tmp_path):
    # Compiling happens in the process that asked for it: a fresh interpreter that warms up
    # and measures (compiling or loading its kernels) has no child process at the end.
    code = ("import os, sys; sys.path.insert(0, sys.argv[1]); import numpy as np; "
            "import radiosim as rs; from radiosim.kernels import compiling; "
            "from test_compiling import _children; "
            "compiling.warmup(frame_dtypes=('float64',), bands=False); "
            "scene = rs.FrameStack(np.full((3, 8, 8), 500.0), dt=1e-6, dx=1e-6); "
            "rs.Camera.linear_ideal(2e-6).measure(scene, 2e-6, t_start=0.0); "
            "print(len(_children(os.getpid())))")
    out = subprocess.run([sys.executable, "-c", code, os.path.dirname(__file__)],
                         capture_output=True, text=True, check=True, cwd=tmp_path)
    assert out.stdout.strip().splitlines()[-1] == "0"

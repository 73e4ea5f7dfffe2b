"""
Benchmark: the paper's largest case, 450 frames of 1440 × 1113 samples, 9 × 9 pixels.

Measures the streaming chain (Camera.measure over a memory-mapped float32 stack) with the linear
ideal camera and with the Planck response (nist-ir preset), the built-in segmented-chip scene's
frames (generated at the same size, 1440 × 1113 samples, as the camera receives them), and the
naive references in the same run:

-   linear: the paper's method done naively — load the window as one float64 array, reshape it
    into p × p × n tensors, take mean, max and std;
-   Planck: direct spectral quadrature per sample (radiometry.band_radiance), timed on a subset
    of samples and reported per sample (running it on 7 × 10⁸ samples would take hours).

Reports throughput [samples/s], peak traced memory [MB] and each case's time as a ratio to one
streaming read of the same frames (numpy sum, warm pages), measured in the same run; each time
is the best of five runs (a shared 2-core machine only ever adds time), and memory is traced in
a separate run. The
compiled kernels alone (without the chain around them) are measured by bench_kernels.py. Run on
demand:

    python benchmarks/bench_integration.py [--frames 450] [--workdir DIR]

The stack (2.9 GB for 450 frames) is written in a temporary folder removed at the end, or in
``--workdir``, where it is kept and read again by the next run given the same folder.
"""

from __future__ import annotations

import argparse
import resource
import shutil
import tempfile
import time
import tracemalloc
import warnings
from pathlib import Path

import numpy as np

import radiosim as rs
from radiosim.radiometry import band_radiance
from radiosim.scenes import SegmentedChip

ROWS, COLS, P = 1113, 1440, 9
DX, DT = 960e-6 / 1440, 0.2e-6


def make_stack(path: Path, n_frames: int) -> np.memmap:
    """A float32 stack of a band moving at cutting speed over a warm gradient."""
    band = rs.MovingGaussianBand(background=293.15, amplitude=719.0, sigma=6e-6,
                                 velocity=250 / 60, x0=100e-6, shape=(ROWS, COLS), dx=DX, dt=DT)
    stack = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32,
                                      shape=(n_frames, ROWS, COLS))
    gradient = 200.0 * np.linspace(0.0, 1.0, ROWS)[:, None]
    for k in range(n_frames):
        stack[k] = band.frame(k) + gradient
    stack.flush()
    del stack
    return np.load(path, mmap_mode="r")


#: Each case runs this many times; its time is the best (the machine's other work only ever
#: adds time), its peak memory is traced in one further run (tracing slows Python down).
REPEATS = 5


def timed(function, repeats: int = REPEATS):
    """(result, best wall time [s], peak traced memory [MB]) of ``function``."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    tracemalloc.start()
    function()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return result, best, peak / 1e6


def numba_threads() -> int:
    import numba

    return numba.get_num_threads()


def naive_linear(stack, n):
    ny, nx = ROWS // P, COLS // P
    block = np.asarray(stack[:n, : ny * P, : nx * P], dtype=np.float64)
    block = block.reshape(n, ny, P, nx, P)
    return block.mean(axis=(0, 2, 4)), block.max(axis=(0, 2, 4)), block.std(axis=(0, 2, 4))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=450)
    parser.add_argument("--workdir", default=None, help="where to write the stack (temp dir)")
    args = parser.parse_args()
    if args.workdir:  # kept: the stack is reused by the next run given the same folder
        Path(args.workdir).mkdir(parents=True, exist_ok=True)
        return run(args, Path(args.workdir))
    workdir = Path(tempfile.mkdtemp(prefix="radiosim-bench-"))
    try:  # a 2.9 GB stack: never left behind in the temporary folder
        return run(args, workdir)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


def run(args, workdir: Path):
    n = args.frames
    path = workdir / f"stack_{n}.npy"
    t0 = time.perf_counter()
    stack = np.load(path, mmap_mode="r") if path.exists() else make_stack(path, n)
    print(f"stack: {n} × {ROWS} × {COLS} float32 ({path.stat().st_size / 1e9:.2f} GB) "
          f"ready in {time.perf_counter() - t0:.1f} s at {path}")
    scene = rs.FrameStack(stack, dt=DT, dx=DX)
    samples = n * ROWS * COLS
    t_int = n * DT

    def streaming_read():
        total = 0.0
        for k in range(n):
            total += float(np.sum(stack[k]))
        return total

    streaming_read()  # warm the page cache, as every case below reads warm pages
    _, t_read, _ = timed(streaming_read)
    linear = rs.Camera.linear_ideal(P * DX)
    linear.measure(scene, DT, t_start=0.0)  # compile (or load) the kernels outside the timing
    m_lin, t_lin, mem_lin = timed(lambda: linear.measure(scene, t_int, t_start=0.0))
    fractional = rs.Camera.linear_ideal(7.3 * DX, fill_factor=0.8)
    _, t_frac, mem_frac = timed(lambda: fractional.measure(scene, t_int, t_start=0.0))
    (mean, peak, std), t_naive, mem_naive = timed(lambda: naive_linear(stack, n), 1)
    err = max(np.max(np.abs(m_lin.apparent_temperature / mean - 1)),
              np.max(np.abs(m_lin.uncertainty - std)) / mean.max())
    assert np.array_equal(m_lin.tensor_max, peak)

    planck = rs.Camera.preset("nist-ir")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.RadiosimWarning)
        planck.measure(scene, DT, t_start=0.0, rng=0)  # compile outside the timing
        _, t_pl, mem_pl = timed(lambda: planck.measure(scene, min(t_int, 1 / 600), t_start=0.0,
                                                       rng=0))
    chip = SegmentedChip()
    assert chip.shape == (ROWS, COLS)
    first = int(round(chip.event_time / chip.dt)) - n // 2  # the frames around the event
    chip.frame(first)  # static fields and the compiled kernel, outside the timing

    def chip_frames():
        for k in range(first, first + n):
            chip.frame(k)

    _, t_chip, mem_chip = timed(chip_frames)
    subset = np.asarray(stack[0, :20, :], dtype=np.float64)
    _, t_quad, _ = timed(lambda: band_radiance(subset, planck.optics.band,
                                               responsivity=planck.responsivity), 1)
    quad_rate = subset.size / t_quad

    print(f"\n{'case':<38}{'time [s]':>10}{'samples/s':>12}{'peak MB':>10}{'× read':>9}")
    rows = [
        ("one streaming read (numpy sum)", t_read, samples / t_read, float("nan")),
        ("linear ideal, streaming", t_lin, samples / t_lin, mem_lin),
        ("linear, 7.3 samples, fill 0.8", t_frac, samples / t_frac, mem_frac),
        ("linear, naive reshape (whole window)", t_naive, samples / t_naive, mem_naive),
        ("planck nist-ir, streaming", t_pl, samples / t_pl, mem_pl),
        ("segmented-chip scene, frames", t_chip, samples / t_chip, mem_chip),
        (f"planck, naive quadrature (on {subset.size})", samples / quad_rate, quad_rate, float("nan")),
    ]
    for name, t, rate, mem in rows:
        print(f"{name:<38}{t:>10.3f}{rate:>12.3g}{mem:>10.0f}{t / t_read:>9.2f}")
    print(f"\nlinear: streaming / naive time = {t_lin / t_naive:.2f}; "
          f"peak memory naive / streaming = {mem_naive / mem_lin:.1f}; "
          f"max relative difference {err:.1e}")
    print(f"planck: streaming is {samples / t_pl / quad_rate:.0f}× faster per sample than direct "
          f"quadrature; planck / linear streaming time = {t_pl / t_lin:.2f}")
    print(f"segmented-chip scene: {n / t_chip:.0f} frames/s, {1e3 * t_chip / n:.2f} ms per "
          f"frame ({numba_threads()} threads)")
    print(f"process max RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3:.0f} MB "
          "(includes the naive reference and mapped pages)")


if __name__ == "__main__":
    main()

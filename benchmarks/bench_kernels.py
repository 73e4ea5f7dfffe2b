"""
Benchmark: the compiled streaming kernels (radiosim.kernels) on the paper's frame size.

A float32 stack of 1113 × 1440 samples per frame, memory-mapped from a .npy file in a temporary
folder, is integrated by 9 × 9-sample pixels. In one run it reports, per frame:

-   streaming read: numpy's sum of each frame (one pass over the data, the yardstick);
-   kernel, linear: pixel_mean of the first frame, then accumulate per frame, no signal;
-   kernel, Planck: the same with the in-band photon radiance of the nist-ir camera's curves
    (3.75–5.15 µm, filter × optics × InSb quantum efficiency; table 150–3000 K, L cubic in T);
-   kernel, non-integer footprint: 7.3-sample pixels with fill factor 0.8, linear;
-   numpy reference: accumulate_reference (linear, 9 × 9), on the first frames only;
-   first call: compile time of the first pixel_mean + accumulate (linear and Planck) in a fresh
    process with an empty numba cache, and again with the on-disk cache filled;
-   peak memory: traced (numpy) allocations of each method, plus the kernels' per-thread scratch.

Each time per frame is the best of ``--repeat`` passes over the frames ("pass"), given as a
ratio to the streaming read's; "frame" is the fastest single frame of those passes, which is
what a pass gives on an idle machine (on a loaded one, a block of a launch whose thread is
descheduled stalls the whole frame for a time slice). The kernels run with numba's thread count
(``--threads``, default all) and, in a second set of rows, with one. Run on demand:

    python benchmarks/bench_kernels.py [--frames 100] [--repeat 3] [--threads N] [--workdir DIR]
"""

from __future__ import annotations

import argparse
import atexit
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numba
import numpy as np

ROWS, COLS, P = 1113, 1440, 9

FIRST_CALL = r"""
import json, sys, time
import numpy as np
t0 = time.perf_counter()
import radiosim.kernels as k
from radiosim.integrator import axis_footprints
from radiosim.radiometry import BandRadianceTable
imported = time.perf_counter() - t0
frame = np.load(sys.argv[1], mmap_mode="r")[0]
rows = axis_footprints(frame.shape[0], 1.0, 9.0, 1.0, 10**6)
cols = axis_footprints(frame.shape[1], 1.0, 9.0, 1.0, 10**6)
shape = (rows.n_pixels, cols.n_pixels)
out = [np.zeros(shape), np.zeros(shape), np.full(shape, -np.inf), np.zeros(shape)]
region = frame[rows.span, cols.span]
t0 = time.perf_counter(); reference = k.pixel_mean(region, rows, cols)
t1 = time.perf_counter(); k.accumulate(region, rows, cols, 1.0, reference, *out[:3])
t2 = time.perf_counter()
table = k.SignalTable(BandRadianceTable(temperature_range=(150.0, 3000.0), per_octave=64))
t3 = time.perf_counter(); k.accumulate(region, rows, cols, 1.0, reference, *out, response=table)
t4 = time.perf_counter()
print(json.dumps({"import": imported, "pixel_mean": t1 - t0, "accumulate": t2 - t1,
                  "accumulate_planck": t4 - t3}))
"""


def make_stack(path: Path, n_frames: int) -> np.memmap:
    """A float32 stack: a hot Gaussian band moving across a warm gradient (293–1300 K)."""
    stack = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32,
                                      shape=(n_frames, ROWS, COLS))
    y = np.arange(ROWS)[:, None]
    x = np.arange(COLS)[None, :]
    gradient = 293.15 + 200.0 * y / ROWS
    for k in range(n_frames):
        centre = 150.0 + 6.25 * k
        stack[k] = gradient + 800.0 * np.exp(-0.5 * ((x - centre - 0.3 * y) / 9.0) ** 2)
    stack.flush()
    del stack
    return np.load(path, mmap_mode="r")


def responsivity_table():
    """The Planck response's table of the nist-ir preset (band and curves of its camera)."""
    from radiosim.radiometry import BandRadianceTable
    from radiosim.spectral import read_spectrum

    curves = [read_spectrum(name) for name in
              ("filter_mwir_3.8-5.1um", "optics_mwir_lens", "qe_insb_77K")]
    band = (3.75e-6, 5.15e-6)
    table = BandRadianceTable(band, "photon", curves, 1.0, (150.0, 3000.0))
    return table, dict(band=band, quantity="photon", responsivity=curves)


def best_of(repeat: int, function) -> tuple[float, float, float]:
    """Best wall time of ``repeat`` calls of ``function(frame_times)`` [s], the fastest frame of
    them [s] (``function`` appends each frame's time to ``frame_times``), and the peak traced
    memory of one call [MB]."""
    tracemalloc.start()
    function([])
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    times, frames = [], []
    for _ in range(repeat):
        start = time.perf_counter()
        function(frames)
        times.append(time.perf_counter() - start)
    return min(times), min(frames), peak


def first_call(path: Path, cache_dir: str) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", FIRST_CALL, str(path)], env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=3, help="passes per method (best kept)")
    parser.add_argument("--reference-frames", type=int, default=5,
                        help="frames for the (slow) numpy reference")
    parser.add_argument("--threads", type=int, default=None, help="numba threads (all)")
    parser.add_argument("--workdir", default=None, help="where to write the stack (temp dir)")
    args = parser.parse_args()
    if args.threads:
        numba.set_num_threads(args.threads)
    threads = numba.get_num_threads()

    from radiosim import kernels
    from radiosim.integrator import axis_footprints

    n = args.frames
    workdir = Path(args.workdir or tempfile.mkdtemp(prefix="radiosim-bench-kernels-"))
    workdir.mkdir(parents=True, exist_ok=True)
    if not args.workdir:  # the stack is not left in the temporary folder (kept in --workdir)
        atexit.register(shutil.rmtree, workdir, True)
    path = workdir / f"stack_{n}.npy"
    stack = np.load(path, mmap_mode="r") if path.exists() else make_stack(path, n)
    for k in range(n):  # page the file in once (and map it), as later passes will find it
        float(stack[k].sum())
    samples = ROWS * COLS
    print(f"stack: {n} × {ROWS} × {COLS} float32 ({path.stat().st_size / 1e9:.2f} GB) at {path}; "
          f"numba {numba.__version__}, {threads} threads "
          f"({numba.threading_layer() if hasattr(numba, 'threading_layer') else '?'})")

    # First-call cost: a cold process, empty cache; then the same with the cache filled.
    with tempfile.TemporaryDirectory(prefix="radiosim-numba-cache-") as cache_dir:
        cold = first_call(path, cache_dir)
        warm = first_call(path, cache_dir)

    def footprints(pitch, fill):
        rows = axis_footprints(ROWS, 1.0, pitch, fill, 10**6)
        cols = axis_footprints(COLS, 1.0, pitch, fill, 10**6)
        return rows, cols

    def window(rows, cols, response=None, frames=n, accumulate=kernels.accumulate,
               mean=kernels.pixel_mean):
        def run(frame_times):
            region = (rows.span, cols.span)
            reference = mean(stack[0][region], rows, cols)
            shape = reference.shape
            dev, sq, signal = np.zeros(shape), np.zeros(shape), np.zeros(shape)
            tmax = np.full(shape, -np.inf)
            weight = 1.0 / frames
            for k in range(frames):
                start = time.perf_counter()
                accumulate(stack[k][region], rows, cols, weight, reference, dev, sq, tmax,
                           signal if response is not None else None, response, frame_index=k)
                frame_times.append(time.perf_counter() - start)
            return dev
        return run

    def read(frame_times):
        for k in range(n):
            start = time.perf_counter()
            float(stack[k].sum())
            frame_times.append(time.perf_counter() - start)

    table, exact = responsivity_table()
    planck = kernels.SignalTable(table, exact)
    integer = footprints(9.0, 1.0)
    fractional = footprints(7.3, 0.8)
    # Compile (or load) everything before timing.
    for rows, cols in (integer, fractional):
        window(rows, cols, frames=1)([])
    window(*integer, response=planck, frames=1)([])

    results = []

    def record(name, function, frames=n, repeat=args.repeat, note=""):
        total, fastest, peak = best_of(repeat, function)
        results.append((name, total / frames, fastest, peak, note))

    record("streaming read (numpy sum)", read)
    cases = [("linear, 9 × 9", integer, None), ("Planck, 9 × 9", integer, planck),
             ("linear, 7.3 samples, fill 0.8", fractional, None),
             ("Planck, 7.3 samples, fill 0.8", fractional, planck)]
    for name, (rows, cols), response in cases:
        record(f"kernel, {name}", window(rows, cols, response))
    if threads > 1:
        numba.set_num_threads(1)
        for name, (rows, cols), response in cases:
            record(f"kernel, {name}, 1 thread", window(rows, cols, response))
        numba.set_num_threads(threads)
    m = min(n, args.reference_frames)
    record("numpy reference, linear, 9 × 9",
           window(*integer, frames=m, accumulate=kernels.accumulate_reference,
                  mean=kernels.pixel_mean_reference), frames=m, repeat=1, note=f"({m} frames)")
    record("numpy reference, Planck, 9 × 9",
           window(*integer, response=planck, frames=m, accumulate=kernels.accumulate_reference,
                  mean=kernels.pixel_mean_reference), frames=m, repeat=1, note=f"({m} frames)")

    read, read_fastest = results[0][1], results[0][2]
    print(f"\n{'method':44s} {'ms/frame':>9s} {'× read':>7s} {'frame ms':>9s} {'× read':>7s} "
          f"{'Msample/s':>10s} {'peak MB':>8s}")
    for name, seconds, fastest, peak, note in results:
        print(f"{name:44s} {seconds * 1e3:9.3f} {seconds / read:7.2f} {fastest * 1e3:9.3f} "
              f"{fastest / read_fastest:7.2f} {samples / seconds / 1e6:10.0f} {peak:8.1f} "
              f"{note}")
    scratch = threads * 14 * COLS * 8 / 1e6
    print(f"(peak MB: traced numpy allocations; the kernels add about {scratch:.2f} MB of "
          "per-thread scratch, and read the frames in place)")
    print("\nfirst call [s]        import  pixel_mean  accumulate  accumulate (Planck)")
    for name, cost in (("empty cache", cold), ("on-disk cache", warm)):
        print(f"{name:20s} {cost['import']:7.2f} {cost['pixel_mean']:11.2f} "
              f"{cost['accumulate']:11.2f} {cost['accumulate_planck']:20.2f}")
    print("targets: linear ≤ 1.5×, Planck ≤ 3×, non-integer ≤ 3× the streaming read")


if __name__ == "__main__":
    main()

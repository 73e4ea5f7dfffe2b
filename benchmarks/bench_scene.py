"""
Benchmark: the segmented-chip scene against the camera on the paper's 90 µs case.

Reports, in one run: the cost of a full-resolution frame (1440 × 1113 samples) with the moving
terms evaluated by the numpy reference and by the compiled kernel (their ratio, and the
kernel's first-call cost: compiling it, in a fresh process without and with numba's on-disk
cache, and in this process), the scene's frame rate alone, the camera's rate on the same frames
when they come from memory (a pre-generated stack, so only the camera works), and the
end-to-end rate of camera.measure on the scene, for the linear ideal camera and the nist-ir
preset (Planck response). Run on demand:

    python benchmarks/bench_scene.py [--frames 450]
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
import warnings

import numba
import numpy as np

import radiosim as rs
from radiosim.scenes import SegmentedChip
from radiosim.scenes.segmented_chip import kernel as chip_kernel

# Run in a fresh process: the first compiled frame of a small grid (the kernel's compilation,
# or its load from the cache) minus a second one, in seconds.
_FIRST_CALL = """
import time
from radiosim.scenes import SegmentedChip
scene = SegmentedChip(dx=16e-6)
scene.geometry
scene._evaluate(0.0, scene._full(), engine="numpy")  # the region's static data
t0 = time.perf_counter()
scene._evaluate(1e-6, scene._full(), engine="compiled")
first = time.perf_counter() - t0
t0 = time.perf_counter()
scene._evaluate(2e-6, scene._full(), engine="compiled")
print(first - (time.perf_counter() - t0))
"""


def first_call_seconds(cache_dir):
    """Compile cost of the kernel in a fresh process whose numba cache is ``cache_dir``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", _FIRST_CALL], env=env, capture_output=True,
                         text=True, check=True)
    return float(out.stdout.split()[-1])


def per_frame(scene, k0, n, compiled):
    """Wall time per frame [s] of the scene's evaluation, median and minimum over n frames."""
    full = scene._full()
    times = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        scene._evaluate((k0 + i + 0.5) * scene.dt, full, engine="compiled" if compiled else "numpy")
        times[i] = time.perf_counter() - t0
    return float(np.median(times)), float(times.min())


def rate(frames, seconds):
    return frames / seconds


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=450, help="90 µs = 450 frames")
    args = parser.parse_args()
    n = args.frames
    with tempfile.TemporaryDirectory() as cache_dir:
        cold = first_call_seconds(cache_dir)  # compiles and writes the cache
        cached = first_call_seconds(cache_dir)  # loads it
    scene = SegmentedChip()
    t0 = time.perf_counter()
    scene.geometry  # static fields, once per grid
    setup = time.perf_counter() - t0
    start = scene.event_time - 0.5 * n * scene.dt
    k0 = int(round(start / scene.dt))

    # The moving terms: numpy reference against the compiled kernel, on the same frames.
    scene._evaluate(start, scene._full(), engine="numpy")  # the region's static data
    t0 = time.perf_counter()
    scene._evaluate(start, scene._full(), engine="compiled")  # + the kernel's run layout
    first = time.perf_counter() - t0
    hits = sum(chip_kernel.moving_terms_kernel.stats.cache_hits.values())
    reference = per_frame(scene, k0, n, engine="numpy")
    compiled = per_frame(scene, k0, n, engine="compiled")

    t0 = time.perf_counter()
    for i in range(n):
        scene.frame(k0 + i)  # evaluated and validated, as the camera receives it
    scene_s = time.perf_counter() - t0
    stack = np.empty((n,) + scene.shape, dtype=np.float32)  # untimed: the stored copy
    for i in range(n):
        stack[i] = scene.frame(k0 + i)
    memory = rs.FrameStack(stack, dt=scene.dt, dx=scene.dx)

    linear = rs.Camera.linear_ideal(6e-6)
    planck = rs.Camera.preset("nist-ir")
    t_int = n * scene.dt
    results = []
    for name, camera in (("linear ideal", linear), ("nist-ir planck", planck)):
        kwargs = {"rng": 0}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rs.RadiosimWarning)
            duration = min(t_int, 1 / 600) if camera.frame_rate else t_int
            t0 = time.perf_counter()
            camera.measure(memory, duration, t_start=0.0, **kwargs)
            alone = time.perf_counter() - t0
            t0 = time.perf_counter()
            camera.measure(scene, duration, t_start=start, **kwargs)
            both = time.perf_counter() - t0
        results.append((name, alone, both))

    print(f"segmented chip, {scene.shape[1]} × {scene.shape[0]} samples, {n} frames "
          f"(static set-up {setup:.2f} s, once per grid)")
    print(f"frame evaluation (static field + moving terms), ms/frame (median, min), "
          f"{numba.get_num_threads()} numba threads: "
          f"numpy reference {1e3 * reference[0]:.2f} ({1e3 * reference[1]:.2f}); compiled "
          f"{1e3 * compiled[0]:.2f} ({1e3 * compiled[1]:.2f}); reference / compiled = "
          f"{reference[0] / compiled[0]:.1f} (min {reference[1] / compiled[1]:.1f})")
    print(f"compiled kernel's first call: {cold:.2f} s compiling (empty cache), {cached:.2f} s "
          f"from the on-disk cache; here {first:.2f} s "
          f"({'cache' if hits else 'compiled'}, with the full grid's run layout)")
    print(f"scene alone: {rate(n, scene_s):7.1f} frames/s ({1e3 * scene_s / n:.1f} ms/frame)")
    for name, alone, both in results:
        print(f"{name:<15} camera on stored frames: {rate(n, alone):6.1f} frames/s; "
              f"camera.measure(scene): {rate(n, both):6.1f} frames/s; "
              f"scene / camera time = {scene_s / alone:.2f}")


if __name__ == "__main__":
    main()

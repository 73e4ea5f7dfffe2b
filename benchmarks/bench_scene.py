"""
Benchmark: the segmented-chip scene against the camera on the paper's 90 µs case.

Reports, in one run: the scene's frame rate alone (full 1440 × 1113 frames), the camera's rate
on the same frames when they come from memory (a pre-generated stack, so only the camera
works), and the end-to-end rate of camera.measure on the scene, for the linear ideal camera and
the nist-ir preset (Planck response). Run on demand:

    python benchmarks/bench_scene.py [--frames 450]
"""

import argparse
import time
import warnings

import numpy as np

import radiosim as rs
from radiosim.scenes import SegmentedChip


def rate(frames, seconds):
    return frames / seconds


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=450, help="90 µs = 450 frames")
    args = parser.parse_args()
    n = args.frames
    scene = SegmentedChip()
    t0 = time.perf_counter()
    scene.geometry  # static fields, once per grid
    setup = time.perf_counter() - t0
    start = scene.event_time - 0.5 * n * scene.dt
    k0 = int(round(start / scene.dt))

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
    print(f"scene alone: {rate(n, scene_s):7.1f} frames/s ({1e3 * scene_s / n:.1f} ms/frame)")
    for name, alone, both in results:
        print(f"{name:<15} camera on stored frames: {rate(n, alone):6.1f} frames/s; "
              f"camera.measure(scene): {rate(n, both):6.1f} frames/s; "
              f"scene / camera time = {scene_s / alone:.2f}")


if __name__ == "__main__":
    main()

"""
Benchmark: the cost of the image stage (point-spread function, reflections) on the paper's grid.

Reports, in one run, on the built-in segmented chip at full resolution (1440 × 1113 samples of
0.667 µm, 0.2 µs frames) and a 10 µs window (50 frames): the wall time of ``camera.measure``
for the ``nist-ir`` camera with a perfect lens (the compiled fast path), with the scene
reflecting a uniform temperature (the image stage, one band, no blur), with diffraction at
1, 4 and 8 spectral sub-bands, and the ``nist-ir-psf`` preset (diffraction, 8 sub-bands, and a
scatter halo) — each as a ratio to the perfect lens — and the time of one blur of a frame-sized
field; then the issue-23 table: ``nist-ir``, ``nist-ir-psf`` and their ratio (the measurement,
and the PSF camera's statistics from one pass over the frames,
:func:`radiosim.imaging.image_statistics`), with the process's peak resident memory after each
case (``resource.getrusage``: it only grows). Each camera measures a 1 µs window first (its
tables and calibration built, as for the perfect lens), then each time is the best of three
(a shared 2-core machine only ever adds time). Run on demand:

    python benchmarks/bench_psf.py [--window-us 10]
"""

import argparse
import dataclasses
import os
import resource
import time
import warnings

import numpy as np

import radiosim as rs
from radiosim.imaging import image_statistics
from radiosim.integrator import integration_window
from radiosim.psf import Diffraction, blur
from radiosim.scenes import SegmentedChip


def timed(function, repeat: int = 1) -> float:
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--window-us", type=float, default=10.0)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore", rs.RadiosimWarning)
    window = args.window_us * 1e-6
    chip = SegmentedChip()
    perfect = rs.Camera.preset("nist-ir")
    perfect.measure(chip, 1e-6, rng=0)  # compile and cache the kernels, build the geometry
    cases = {"perfect lens": (perfect, None)}
    cases["reflecting scene (no PSF)"] = (perfect, 293.15)
    for n in (1, 4, 8):
        cases[f"diffraction, {n} sub-band{'s' * (n > 1)}"] = (
            perfect.replace(optics=dataclasses.replace(perfect.optics, psf=Diffraction(n))),
            None)
    cases["nist-ir-psf (diffraction 8 + halo)"] = (rs.Camera.preset("nist-ir-psf"), None)
    times, peaks = {}, {}
    for label, (camera, reflected) in cases.items():
        chip.set_environment(reflected_temperature=reflected)
        camera.measure(chip, 1e-6, rng=0)  # each camera's tables built, as the perfect lens's
        times[label] = timed(lambda: camera.measure(chip, window, rng=0), 3)  # best of 3
        peaks[label] = peak_mib()
    chip.set_environment()
    psf_camera = cases["nist-ir-psf (diffraction 8 + halo)"][0]
    optics = psf_camera.optics
    span = integration_window(chip, window)
    one_pass = timed(lambda: image_statistics(
        chip, psf_camera.integrator(chip), span, psf_camera.response_model, optics.psf,
        optics.band, optics.object_na(psf_camera.fpa)), 3)
    one_pass_peak = peak_mib()
    field = np.random.default_rng(0).uniform(1e20, 1e21, chip.shape)
    na = perfect.optics.object_na(perfect.fpa)
    one_blur = timed(lambda: blur(field, 1e20, [Diffraction()], chip.dx, 4.5e-6, na), 2)
    base = times["perfect lens"]
    print(f"segmented chip {chip.shape[1]} × {chip.shape[0]} samples, {args.window_us:g} µs "
          f"window ({round(window / chip.dt)} frames), 2 cores")
    print(f"{'case':<38}{'wall [s]':>10}{'÷ perfect lens':>16}")
    for label, seconds in times.items():
        print(f"{label:<38}{seconds:>10.2f}{seconds / base:>16.1f}")
    print(f"one blur of a frame-sized field (diffraction, one sub-band): {one_blur:.2f} s")
    psf = times["nist-ir-psf (diffraction 8 + halo)"]
    print()
    print(f"issue 23 (load average {os.getloadavg()[0]:.1f} at the end)")
    print(f"{'case':<52}{'wall [s]':>10}{'÷ nist-ir':>11}{'peak RSS [MiB]':>16}")
    print(f"{'nist-ir (no PSF)':<52}{base:>10.2f}{1:>11.1f}{peaks['perfect lens']:>16.0f}")
    print(f"{'nist-ir-psf (8-sub-band diffraction + 2 % halo)':<52}{psf:>10.2f}"
          f"{psf / base:>11.1f}{peaks['nist-ir-psf (diffraction 8 + halo)']:>16.0f}")
    print(f"{'nist-ir-psf statistics in one pass (image_statistics)':<52}{one_pass:>10.2f}"
          f"{one_pass / base:>11.1f}{one_pass_peak:>16.0f}")


def peak_mib() -> float:
    """The process's peak resident memory so far [MiB] (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


if __name__ == "__main__":
    main()

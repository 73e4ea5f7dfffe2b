"""
Benchmark: real-camera sizes (issue 41), as ratios to drawing one frame's noise, in one run.

Reports the best of five (a shared 2-core machine only ever adds time):

-   the reference: drawing a 1024 × 1024 frame's shot and read noise (numpy's Poisson and
    normal generators, what :meth:`radiosim.electronics.Electronics.expose` draws);
-   a ``nist-ir`` measurement of a static 1024 × 1024 frame (one frame of 6 µm samples, a
    1 µs window), and the calibration's inversion of its counts alone;
-   converting a 640 × 512 FLIR frame to temperature through its own curve
    (:func:`radiosim.flir.raw_to_temperature`), and a 640 × 512 PTW-like frame of counts
    through a radiosim camera's calibration;
-   exporting a 1000-frame recording (640 × 512, a .seq written here) to NetCDF: the time,
    and the process's peak resident memory before and after (``resource.getrusage``; the
    recording's counts are 655 MB, its temperatures 2.6 GB).

Run on demand:

    python benchmarks/bench_recording.py
"""

import dataclasses
import resource
import tempfile
import time
from pathlib import Path

import numpy as np
from _host import best

import radiosim as rs
from radiosim.flir import ObjectParameters, PlanckCurve, raw_to_temperature
from radiosim.scenes import FrameStack

FLIR = Path(__file__).resolve().parents[1] / "tests" / "data" / "flir" / "frame_000000.fff"

def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main():
    rng = np.random.default_rng(0)
    base = rs.Camera.preset("nist-ir")
    camera = base.replace(fpa=dataclasses.replace(base.fpa, shape=(1024, 1024)))
    frame = 600.0 + 400.0 * rng.random((1, 1024, 1024))
    scene = FrameStack(frame.repeat(2, 0), dt=1e-6, dx=6e-6)
    m = camera.measure(scene, 1e-6, rng=1)  # compiled, tables built
    electrons = m.electrons
    noise = best(lambda: (rng.poisson(electrons), rng.normal(0.0, 600.0, electrons.shape)))
    measure = best(lambda: camera.measure(scene, 1e-6, rng=1))
    calibration = camera.calibration(1e-6)
    invert = best(lambda: calibration.invert(m.counts))
    print(f"noise of a 1024 × 1024 frame            {noise * 1e3:8.1f} ms  (1.00)")
    print(f"nist-ir measurement, 1024 × 1024        {measure * 1e3:8.1f} ms  "
          f"({measure / noise:.2f})")
    print(f"  of which the inversion of its counts  {invert * 1e3:8.1f} ms  "
          f"({invert / noise:.2f})")

    recording = rs.read_recording(FLIR)
    raw = recording.frames(0)[0]
    p = ObjectParameters(**recording.metadata["object_parameters"])
    curve: PlanckCurve = recording.curve
    flir = best(lambda: raw_to_temperature(raw, curve, p))
    counts = np.rint(m.counts[:512, :640])
    ptw = best(lambda: calibration.temperature(counts))
    noise_640 = best(lambda: (rng.poisson(electrons[:512, :640]),
                              rng.normal(0.0, 600.0, (512, 640))))
    print(f"noise of a 640 × 512 frame              {noise_640 * 1e3:8.1f} ms  (1.00)")
    print(f"FLIR frame to temperature, 640 × 512    {flir * 1e3:8.1f} ms  "
          f"({flir / noise_640:.2f})")
    print(f"counts through a camera, 640 × 512      {ptw * 1e3:8.1f} ms  "
          f"({ptw / noise_640:.2f})")

    with tempfile.TemporaryDirectory() as folder:
        one = FLIR.read_bytes()
        seq = Path(folder) / "long.seq"
        with open(seq, "wb") as out:
            for _ in range(1000):
                out.write(one)
        long = rs.read_recording(seq)
        before = peak_mb()
        start = time.perf_counter()
        from radiosim.io.recordings import export_recording

        export_recording(long, Path(folder) / "long.nc")
        took = time.perf_counter() - start
        print(f"1000 frames of 640 × 512 to NetCDF      {took:8.1f} s; peak memory "
              f"{before:.0f} → {peak_mb():.0f} MB (the temperatures alone: "
              f"{long.counts.size * 8 / 1e6:.0f} MB)")


if __name__ == "__main__":
    main()

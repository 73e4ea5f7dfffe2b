"""
Benchmark: a correction against the measurement it corrects (issue 42: at most 1×), in one run.

The ``nist-ir-psf`` camera (diffraction in 8 sub-bands and a scatter halo) with a 1113 × 1440
pixel array measures a static frame of as many samples (a hot square on a warm background;
one sample a pixel), warm; then :func:`radiosim.correction.correct` corrects it. Both the best
of three. Run on demand:

    python benchmarks/bench_correction.py
"""

import dataclasses

import numpy as np
from _host import best

import radiosim as rs
from radiosim.correction import correct
from radiosim.scenes import FrameStack

def main():
    base = rs.Camera.preset("nist-ir-psf")
    camera = base.replace(fpa=dataclasses.replace(base.fpa, shape=(1113, 1440)))
    pitch = camera.fpa.pixel_pitch
    frame = np.full((1113, 1440), 500.0)
    frame[500:540, 700:760] = 1100.0
    scene = FrameStack(frame[None].repeat(2, 0), dt=10e-6, dx=pitch)
    m = camera.measure(scene, 10e-6, rng=1)  # compiled, tables built
    correct(m)
    measure = best(lambda: camera.measure(scene, 10e-6, rng=1), 3)
    fix = best(lambda: correct(m), 3)
    print(f"nist-ir-psf measurement, 1113 × 1440 pixels  {measure:7.2f} s")
    print(f"its correction                               {fix:7.2f} s  ({fix / measure:.2f} ×)")


if __name__ == "__main__":
    main()

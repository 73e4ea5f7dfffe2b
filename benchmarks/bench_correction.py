"""
Benchmark: a correction against the measurement it corrects (issue 42: at most 1×), and the
closed-loop size-of-source bias on the paper's chip, in one run.

1.  The ``nist-ir-psf`` camera (diffraction in 8 sub-bands and a scatter halo) with a 1113 ×
    1440 pixel array measures a static frame of as many samples (a hot square on a warm
    background; one sample a pixel), warm; then :func:`radiosim.correction.correct` corrects
    it. Both the best of three.
2.  The built-in segmented chip at the paper's resolution (1440 × 1113 samples, 0.667 µm)
    measured by ``nist-ir-psf`` (6 µm pixels, noise-free) over one frame at the event, and by
    the same camera with a perfect lens (the truth the correction aims at): the bias at the
    paper's Column I shear-band pixel and the rms over the pixels above 400 °C, raw and
    corrected; and the times of a 45 µs chip measurement and of its correction.

Run on demand:

    python benchmarks/bench_correction.py
"""

import dataclasses

import numpy as np
from _host import best

import radiosim as rs
from radiosim.correction import correct
from radiosim.paper.columns import column_index
from radiosim.scenes import FrameStack, SegmentedChip


def large_frame():
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


def chip():
    scene = SegmentedChip()
    base = rs.Camera.preset("nist-ir-psf")
    ideal = dataclasses.replace(base.electronics, read_noise=0.0, shot_noise=False,
                                adc_bits=None)
    camera = base.replace(fpa=dataclasses.replace(base.fpa, shape=None, fill_factor=1.0),
                          electronics=ideal)
    perfect = camera.replace(optics=dataclasses.replace(base.optics, psf=None))
    truth = perfect.measure(scene, scene.dt).apparent_temperature
    m = camera.measure(scene, scene.dt)
    c = correct(m)
    col = column_index(scene, camera.fpa.pixel_pitch)
    row = int(np.nanargmax(truth[:, col]))
    hot = truth > 673.15
    ok = hot & np.isfinite(c.temperature)
    raw_band = m.apparent_temperature[row, col] - truth[row, col]
    fixed_band = c.temperature[row, col] - truth[row, col]
    raw_rms = np.sqrt(np.mean((m.apparent_temperature - truth)[hot] ** 2))
    fixed_rms = np.sqrt(np.mean((c.temperature - truth)[ok] ** 2))
    print(f"chip, 6 µm pixels, one frame: Column I band {raw_band:+.1f} K raw, "
          f"{fixed_band:+.2f} K corrected ({abs(raw_band / fixed_band):.0f}× less)")
    print(f"  above 400 °C rms {raw_rms:.1f} K raw, {fixed_rms:.1f} K corrected "
          f"({100 * ok.sum() / hot.sum():.0f} % of those pixels trusted)")
    measure = best(lambda: camera.measure(scene, 45e-6), 1)
    m45 = camera.measure(scene, 45e-6)
    fix = best(lambda: correct(m45), 3)
    print(f"chip, 45 µs measurement {measure:.2f} s, its correction {fix:.3f} s "
          f"({fix / measure:.3f} ×)")


if __name__ == "__main__":
    large_frame()
    chip()

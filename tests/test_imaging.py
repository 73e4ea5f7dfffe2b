"""
The image stage's fast paths (issue 23): all sub-bands from one table lookup per sample
against the per-sub-band reference, the statistics and the image from one pass over the
frames, and the blur's padding and sub-band merging within their stated bounds.
"""

import dataclasses

import numpy as np
import pytest

import radiosim as rs
from radiosim import acquisition
from radiosim.imaging import image_signal, image_statistics
from radiosim.integrator import Job, Window, integrate_many
from radiosim.kernels.bands import launch_bands
from radiosim.kernels.reference import accumulate_bands_reference
from radiosim.psf import Diffraction, GaussianBlur, ScatterHalo, _cached_transfer, _kernel_distance, \
    blur_bands, fft_shape, padding
from radiosim.scenes import FrameStack

RNG = np.random.default_rng(23)


def psf_camera():
    camera = rs.Camera.preset("nist-ir-psf")
    return camera.replace(fpa=dataclasses.replace(camera.fpa, shape=(5, 6)))


def stack_scene(n_frames=4, shape=(40, 52), cold=None):
    t = RNG.uniform(300.0, 1100.0, (n_frames, *shape))
    if cold is not None:
        t[1, 3:5, 7:9] = cold  # below the 130 K table
    return FrameStack(t, dt=2e-7, dx=6.0e-6 / 9)


@pytest.mark.parametrize("emissivity", ["scalar", "map", "index"])
def test_fused_sub_band_kernel_equals_the_per_sub_band_reference(emissivity):
    camera = psf_camera()
    subs = [r for r, _ in camera.response_model.sub_bands(8)]
    shape = (9, 21)
    block = RNG.uniform(250.0, 1500.0, (3, *shape))
    weights = np.array([0.2, 0.5, 0.3])
    frame = rs.scenes.SceneFrame(block[0], 0.7)
    tables = [s.signal_table(frame) for s in subs]
    if emissivity == "map":
        grey = RNG.uniform(0.1, 0.9, shape)
        tables = [t.with_maps(grey=grey) for t in tables]
    elif emissivity == "index":
        regions = {0: 0.3, 1: 0.8}
        codes = RNG.integers(0, 2, shape).astype(np.uint8)
        frame = rs.scenes.SceneFrame(block[0], 1.0, codes, regions)
        tables = [s.signal_table(frame) for s in subs]
    fused, reference = np.zeros((8, *shape)), np.zeros((8, *shape))
    status, rows = launch_bands(block, weights, tables, fused)
    assert status == 0 and rows.size == 0
    accumulate_bands_reference(block, weights, tables, reference)
    assert np.all(reference > 0)
    assert np.max(np.abs(fused / reference - 1)) < 1e-12


def test_one_pass_gives_the_statistics_and_image_of_two_passes():
    camera = psf_camera()
    scene = stack_scene()
    window = Window(0.0, 3 * scene.dt)
    integrator = camera.integrator(scene)
    optics = camera.optics
    args = (camera.response_model, optics.psf, optics.band, optics.object_na(camera.fpa))
    one = image_statistics(scene, integrator, window, *args)
    truth = integrate_many(scene, [Job(integrator, window, camera.response_model)],
                           emission_only=True)[0]
    image = image_signal(scene, integrator, window, *args)
    for name in ("mean", "std", "max"):
        assert np.array_equal(getattr(one, name), getattr(truth, name)), name
    assert one.n_frames == truth.n_frames == 3
    assert np.array_equal(one.signal_mean, image)
    # and what the measurement's statistics give today
    (stats,) = acquisition.tensor_statistics(scene, [camera.exposure(scene, window)])
    assert np.array_equal(stats.mean, one.mean)
    assert np.max(np.abs(stats.signal_mean / one.signal_mean - 1)) < 1e-12


def test_samples_below_the_table_take_the_exact_reference():
    camera = psf_camera()
    scene = stack_scene(cold=100.0)
    subs = [r for r, _ in camera.response_model.sub_bands(8)]
    window = Window(0.0, 3 * scene.dt)
    compiled = rs.imaging.sample_signals(scene, window, subs)
    reference = rs.imaging.sample_signals(scene, window, subs, engine="numpy")
    assert np.max(np.abs(compiled / reference - 1)) < 1e-12


def test_a_uniform_reflection_adds_the_same_bits_as_its_pass_over_the_frame(monkeypatch):
    camera = psf_camera()
    scene = FrameStack(RNG.uniform(300.0, 1100.0, (4, 12, 17)), dt=2e-7, dx=6.0e-6 / 9,
                       emissivity=0.6).set_environment(reflected_temperature=293.15)
    subs = [r for r, _ in camera.response_model.sub_bands(8)]
    window = Window(0.3 * scene.dt, 3 * scene.dt)
    taken = []
    uniform = rs.imaging.SubBandSignals._add_uniform
    monkeypatch.setattr(rs.imaging.SubBandSignals, "_add_uniform",
                        lambda self, *a: taken.append(uniform(self, *a)) or taken[-1])
    shortcut = rs.imaging.sample_signals(scene, window, subs)
    assert taken and all(taken)
    monkeypatch.setattr(rs.imaging.SubBandSignals, "_add_uniform", lambda self, *a: False)
    full = rs.imaging.sample_signals(scene, window, subs)  # the kernel over every sample
    assert np.array_equal(shortcut, full)
    emission = rs.imaging.sample_signals(scene.set_environment(), window, subs)
    assert np.all(full > emission)  # the reflection is there


def hot_disc(shape=(60, 70)):
    y, x = np.indices(shape)
    return np.where(np.hypot(y - 30, x - 25) < 6, 100.0, 1.0)


def test_padding_leaves_less_than_the_stated_energy_of_the_contrast():
    psfs = (GaussianBlur(1e-6), ScatterHalo(0.02, 2e-6))
    dx, na, wavelength = 0.5e-6, 0.2, 4.5e-6
    field = hot_disc()
    energy, wide_energy = 1e-2, 1e-3
    padded = blur_bands([field], [1.0], psfs, dx, [wavelength], na, energy=energy)
    wide = blur_bands([field], [1.0], psfs, dx, [wavelength], na, energy=wide_energy)
    pads = [padding(psfs, wavelength, na, e) / dx for e in (energy, wide_energy)]
    assert pads[0] < pads[1] < 4 * min(field.shape)  # neither capped
    error = np.abs(padded - wide).max()
    assert 0 < error <= (energy + wide_energy) * (field.max() - 1.0)


def test_merged_sub_bands_stay_within_the_kernel_distance_bound():
    psfs = (Diffraction(),)
    dx, na = 0.5e-6, 0.2
    fields = [hot_disc(), 0.5 * hot_disc()]
    waves = [4.50e-6, 4.52e-6]
    shape = fft_shape(fields[0].shape, max(padding(psfs, w, na) for w in waves) / dx)
    distance = _kernel_distance(*(_cached_transfer(psfs, shape, dx, w, na) for w in waves),
                                shape)
    apart = blur_bands(fields, [1.0, 0.5], psfs, dx, waves, na, tolerance=0.0)
    merged = blur_bands(fields, [1.0, 0.5], psfs, dx, waves, na, tolerance=2 * distance)
    error = np.abs(apart - merged).max()
    assert 0 < error <= distance * (fields[1].max() - 0.5) * (1 + 1e-9)


def test_the_one_pass_image_sees_each_frames_own_reflected_temperature():
    # A frame stack whose reflected temperature changes from frame to frame: the image the
    # measurement's one pass forms (image_statistics) equals the image formed frame by frame
    # (Camera.image), to rounding. (Before, a block of frames took its first frame's reflected
    # temperature: 0.7 % off here.)
    rng = np.random.default_rng(4)
    stack = 400.0 + 500.0 * rng.random((5, 18, 24))
    reflected = np.array([300.0, 350.0, 400.0, 450.0, 500.0])
    camera = psf_camera()
    scene = FrameStack(stack, dt=1e-6, dx=1e-6, emissivity=0.8).set_environment(
        reflected_temperature=reflected, surroundings_temperature=350.0)
    window = Window(0.3e-6, 3.4e-6)
    optics = camera.optics
    one = image_statistics(scene, camera.integrator(scene), window, camera.response_model,
                           optics.psf, optics.band, optics.object_na(camera.fpa))
    np.testing.assert_allclose(one.signal_mean, camera.image(scene, window), rtol=1e-12)


def test_float32_blocks_are_widened_a_few_frames_at_a_time(monkeypatch):
    # The sub-band kernel reads float64: a float32 block is widened at most WIDEN_BYTES at a
    # time (here one frame per kernel call), and the sums are the reference's to 1e-12.
    from radiosim.kernels import bands

    camera = psf_camera()
    subs = [r for r, _ in camera.response_model.sub_bands(4)]
    block = RNG.uniform(250.0, 1500.0, (5, 9, 21)).astype(np.float32)
    weights = np.full(5, 0.2)
    tables = [s.signal_table(rs.scenes.SceneFrame(block[0], 0.7)) for s in subs]
    calls = []
    launch = bands.launch_bands
    monkeypatch.setattr(bands, "launch_bands",
                        lambda b, *a, **k: calls.append(b.shape[0]) or launch(b, *a, **k))
    monkeypatch.setattr(bands, "WIDEN_BYTES", 8 * 9 * 21)
    fused, reference = np.zeros((4, 9, 21)), np.zeros((4, 9, 21))
    assert bands.accumulate_bands(block, weights, tables, fused) == 0
    assert calls == [1] * 5
    accumulate_bands_reference(block, weights, tables, reference)
    assert np.max(np.abs(fused / reference - 1)) < 1e-12

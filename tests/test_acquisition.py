"""radiosim.acquisition: the stages Camera.measure and measure_many share, and progress."""

import dataclasses

import numpy as np

from radiosim import Camera, MovingGaussianBand
from radiosim.acquisition import measure_many, photoelectrons, readout_shape
from radiosim.psf import ScatterHalo


def _band():
    return MovingGaussianBand(shape=(24, 32), dx=1e-6, dt=1e-6, n_frames=20)


def _small(camera):
    return camera.replace(fpa=dataclasses.replace(camera.fpa, shape=(6, 8)))


def test_measure_reports_each_frame_and_changes_no_bit():
    camera = _small(Camera.preset("nist-ir").with_pixel_pitch(3e-6))
    calls = []
    m = camera.measure(_band(), 5e-6, 4e-6, rng=1, progress=lambda *a: calls.append(a))
    quiet = camera.measure(_band(), 5e-6, 4e-6, rng=1)
    np.testing.assert_array_equal(m.counts, quiet.counts)
    np.testing.assert_array_equal(m.apparent_temperature, quiet.apparent_temperature)
    # The window holds 5 frames of 1 µs: the last call says all 5 of 5 are done.
    assert calls and calls[-1] == (5, 5) and all(t == 5 for _, t in calls)
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)


def test_progress_counts_the_one_pass_of_an_imaging_camera():
    camera = _small(Camera.preset("nist-ir").with_pixel_pitch(3e-6))
    camera = camera.replace(optics=dataclasses.replace(camera.optics,
                                                       psf=ScatterHalo(0.05, 6e-6)))
    calls = []
    camera.measure(_band(), 5e-6, 4e-6, rng=1, progress=lambda *a: calls.append(a))
    # The scene truth's statistics and the image from one pass over the window's 5 frames
    # (imaging.image_statistics): counted once, per kernel call (small generated frames go
    # in blocks: frame_reading.stacked), rising to 5 of 5.
    assert calls[-1] == (5, 5) and all(t == 5 for _, t in calls)
    done = [d for d, _ in calls]
    assert done == sorted(set(done)) and done[-1] == 5


def test_measure_many_equals_measure_in_turn_and_a_rolling_shutter_joins_it():
    scene = _band()
    nist = _small(Camera.preset("nist-ir").with_pixel_pitch(3e-6))
    rolling = nist.replace(fpa=dataclasses.replace(nist.fpa, shutter="rolling", row_time=1e-6))
    cases = [(nist, 5e-6, 4e-6), (rolling, 3e-6, 2e-6), (Camera.linear_ideal(4e-6), 2e-6, 0.0)]
    together = measure_many(scene, cases, rng=9)
    rng = np.random.default_rng(9)
    for (camera, t_int, t_start), m in zip(cases, together):
        alone = camera.measure(scene, t_int, t_start, rng)
        np.testing.assert_array_equal(m.counts, alone.counts)
        np.testing.assert_array_equal(m.tensor_max, alone.tensor_max)


def test_photoelectrons_add_the_optics_emission_through_the_etendue():
    camera = Camera.preset("nist-ir")
    signal = np.array([[1e18, 2e18]])  # [photons s⁻¹ m⁻² sr⁻¹]
    emission = camera.optics.emitted_radiance(camera.fpa.quantum_efficiency)
    expected = (signal + emission) * camera.etendue * 10e-6  # rate per signal: the étendue
    np.testing.assert_allclose(photoelectrons(camera.readout(10e-6), signal, 10e-6), expected,
                               rtol=1e-12)
    # Linear: 10⁶ e⁻ s⁻¹ K⁻¹ (linear_responsivity) × T × t, no optics' emission.
    temperature = np.array([[300.0, 900.0]])  # [K]
    linear = Camera.linear_ideal(6e-6)
    np.testing.assert_allclose(photoelectrons(linear.readout(2e-6), temperature, 2e-6),
                               temperature * 1e6 * 2e-6, rtol=1e-15)


def test_readout_shape_is_the_array_or_one_pixel():
    assert readout_shape(Camera.preset("nist-ir")) == (120, 160)
    assert readout_shape(Camera.linear_ideal(6e-6)) == (1, 1)

"""The integrator and the linear ideal camera against naive and brute-force references."""

import dataclasses
import tracemalloc

import numpy as np
import pytest

from radiosim import Camera, FocalPlaneArray, FrameStack, MovingGaussianBand
from radiosim.errors import RadiosimError
from radiosim.integrator import FootprintIntegrator, Window, axis_footprints, integrate
from radiosim.response import LinearResponse


def naive_tensors(stack, p, first, n):
    """The paper's method: reshape into p × p × n tensors and take mean, max and std."""
    frames, rows, cols = stack.shape
    ny, nx = rows // p, cols // p
    block = stack[first:first + n, : ny * p, : nx * p].reshape(n, ny, p, nx, p)
    return block.mean(axis=(0, 2, 4)), block.max(axis=(0, 2, 4)), block.std(axis=(0, 2, 4))


@pytest.mark.parametrize("p, n, first", [(9, 5, 0), (9, 50, 7), (3, 1, 4), (21, 1, 0),
                                          (6, 13, 3), (1, 2, 1)])
def test_linear_ideal_equals_the_naive_tensor_reference(p, n, first):
    rng = np.random.default_rng(p * 100 + n)
    dx, dt = 0.6667e-6, 0.2e-6  # the paper's 9 samples per 6 µm pixel: not exact in floats
    stack = rng.uniform(290.0, 1015.0, (first + n + 2, 47, 65))
    scene = FrameStack(stack, dt=dt, dx=dx)
    m = Camera.linear_ideal(p * dx).measure(scene, n * dt, t_start=first * dt)
    mean, peak, std = naive_tensors(stack, p, first, n)
    assert m.n_frames == n
    assert m.shape == mean.shape
    np.testing.assert_allclose(m.apparent_temperature, mean, rtol=1e-12, atol=0)
    np.testing.assert_allclose(m.tensor_mean, mean, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(m.tensor_max, peak)
    np.testing.assert_allclose(m.peak_error, peak - mean, rtol=1e-12, atol=1e-12 * 1015)
    np.testing.assert_allclose(m.uncertainty, std, rtol=1e-12, atol=1e-12 * 1015)
    assert not m.saturated.any() and not m.under_range.any()


def test_uniform_regions_have_zero_uncertainty():
    stack = np.full((20, 18, 18), 812.3)
    m = Camera.linear_ideal(6.0).measure(FrameStack(stack, dt=1.0, dx=1.0), 20.0, t_start=0.0)
    assert np.all(m.uncertainty < 1e-12 * 812.3)
    np.testing.assert_allclose(m.apparent_temperature, 812.3, rtol=1e-15)


def supersampled_reference(stack, s, time_factor, pitch, active, origin, t0, t1):
    """Brute force: refine space by s and time by `time_factor`, then plain averages.

    All footprint edges and window ends must fall on the refined grid.
    """
    fine = np.repeat(np.repeat(np.repeat(stack, time_factor, 0), s, 1), s, 2)
    window = fine[int(round(t0 * time_factor)): int(round(t1 * time_factor))]
    ny = int((stack.shape[1] - origin) // pitch)
    nx = int((stack.shape[2] - origin) // pitch)
    mean, peak, std = (np.empty((ny, nx)) for _ in range(3))
    for i in range(ny):
        for j in range(nx):
            y0 = int(round((origin + i * pitch + (pitch - active) / 2) * s))
            x0 = int(round((origin + j * pitch + (pitch - active) / 2) * s))
            w = int(round(active * s))
            tensor = window[:, y0:y0 + w, x0:x0 + w]
            mean[i, j], peak[i, j], std[i, j] = tensor.mean(), tensor.max(), tensor.std()
    return mean, peak, std


@pytest.mark.parametrize("pitch, fill, origin, t0, duration", [
    (2.5, 1.0, 0.0, 0.0, 3.0),      # pixels split samples
    (2.5, 0.64, 0.5, 0.5, 3.25),    # active 2.0 of 2.5, offset origin, fractional window
    (3.0, 0.25, 1.25, 1.75, 2.5),   # small fill factor, quarter-sample edges
    (4.0, 0.5625, 0.0, 0.25, 0.5),  # window inside a frame pair
])
def test_non_integer_footprints_and_windows_match_brute_force(pitch, fill, origin, t0, duration):
    rng = np.random.default_rng(11)
    stack = rng.uniform(300.0, 900.0, (8, 17, 19))
    scene = FrameStack(stack, dt=1.0, dx=1.0)
    camera = Camera.linear_ideal(pitch).replace(
        fpa=FocalPlaneArray(pixel_pitch=pitch, fill_factor=fill, origin=(origin, origin)))
    m = camera.measure(scene, duration, t_start=t0)
    mean, peak, std = supersampled_reference(stack, 4, 4, pitch, pitch * np.sqrt(fill), origin,
                                             t0, t0 + duration)
    np.testing.assert_allclose(m.apparent_temperature, mean, rtol=1e-12)
    np.testing.assert_array_equal(m.tensor_max, peak)
    np.testing.assert_allclose(m.uncertainty, std, rtol=1e-10, atol=1e-12 * 900)


def test_moving_band_converges_to_its_closed_form_blur():
    # A pixel much narrower than the band, a long window: the camera reads the time average.
    band = MovingGaussianBand(300.0, 600.0, sigma=8e-6, velocity=4.0, x0=20e-6,
                              shape=(4, 400), dx=0.25e-6, dt=0.01e-6)
    t_int = 10e-6
    m = Camera.linear_ideal(1e-6).measure(band, t_int, t_start=0.0)
    x = (np.arange(m.shape[1]) + 0.5) * 1e-6
    expected = band.time_average(x, 0.0, t_int)
    # Errors: midpoint rule in time and box average over a 1 µm pixel, both O((h/σ)²).
    np.testing.assert_allclose(m.apparent_temperature[0], expected, rtol=0, atol=0.5)


def _peak_traced_memory(n_frames):
    band = MovingGaussianBand(shape=(300, 300), dx=1e-6, dt=1e-7)
    camera = Camera.linear_ideal(5e-6)
    tracemalloc.start()
    camera.measure(band, n_frames * 1e-7, t_start=0.0)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak


def test_peak_memory_does_not_grow_with_frames():
    small, large = _peak_traced_memory(10), _peak_traced_memory(200)
    assert large < 1.1 * small


def test_scene_smaller_than_the_array_and_larger_one_cropped():
    stack = np.full((2, 20, 31), 500.0)
    scene = FrameStack(stack, dt=1.0, dx=1.0)
    m = Camera.linear_ideal(3.0, shape=(100, 100)).measure(scene, 1.0, t_start=0.0)
    assert m.shape == (6, 10)  # only whole pixels the scene covers
    m = Camera.linear_ideal(3.0, shape=(2, 4)).measure(scene, 1.0, t_start=0.0)
    assert m.shape == (2, 4)  # aligned on the scene's top-left corner


def test_footprint_larger_than_the_frame_is_refused():
    scene = FrameStack(np.full((2, 20, 31), 500.0), dt=1.0, dx=1.0)
    with pytest.raises(RadiosimError, match="no whole pixel fits along y"):
        Camera.linear_ideal(21.0).measure(scene, 1.0, t_start=0.0)


def test_axis_pieces_weights_sum_to_one():
    ax = axis_footprints(100, 0.7e-6, 6.1e-6, 0.81, max_pixels=50, origin=0.3e-6)
    sums = np.add.reduceat(ax.weight, ax.starts)
    np.testing.assert_allclose(sums, 1.0, rtol=1e-14)
    integrator = FootprintIntegrator(ax, ax)
    assert integrator.shape == (ax.n_pixels, ax.n_pixels)


class Square(LinearResponse):
    """A response whose signal is T² [K²]: not the temperature, so accumulated on its own
    (a response without a kernel form: the numpy engine integrates it)."""

    has_table = False

    def signal(self, frame):
        return frame.temperature**2


def test_integrate_accumulates_the_signal_separately():
    scene = FrameStack(np.random.default_rng(2).uniform(300, 600, (4, 12, 12)), dt=1.0, dx=1.0)
    integrator = FootprintIntegrator.for_scene(scene, 3.0, 1.0, (4, 4))
    stats = integrate(scene, integrator, Window(0.0, 4.0), Square())
    block = scene._stack.reshape(4, 4, 3, 4, 3)
    np.testing.assert_allclose(stats.signal_mean, (block**2).mean(axis=(0, 2, 4)), rtol=1e-12)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_one_pass_many_measurements_equals_one_at_a_time(engine, monkeypatch):
    # Overlapping and disjoint windows, two pixel sizes, linear and Planck responses, per-region
    # emissivity: one pass over the frames gives every measurement, noise included — to
    # rounding with either engine (the jobs of one footprint group share a reference).
    import radiosim.integrator as integrator_module
    from radiosim.camera import measure_many
    from radiosim.scenes import SegmentedChip

    scene = SegmentedChip(dx=4e-6, dt=1e-6, emissivity={"chip": 0.3, "tool": 0.5})
    nist = Camera.preset("nist-ir")
    cases = [(Camera.linear_ideal(8e-6), 5e-6, None), (nist, 5e-6, None),
             (nist.with_pixel_pitch(12e-6), 3e-6, 10e-6), (Camera.linear_ideal(8e-6), 2.5e-6, 0.0),
             (nist, 20e-6, None)]
    many = integrator_module.integrate_many
    monkeypatch.setattr(integrator_module, "integrate_many",
                        lambda *a, **k: many(*a, **{**k, "engine": engine}))
    together = measure_many(scene, cases, rng=7)
    rng = np.random.default_rng(7)
    for (camera, t_int, t_start), m in zip(cases, together):
        alone = camera.measure(scene, t_int, t_start, rng)
        np.testing.assert_array_equal(m.tensor_max, alone.tensor_max)
        for name in ("apparent_temperature", "tensor_mean", "signal_mean"):
            np.testing.assert_allclose(getattr(m, name), getattr(alone, name), rtol=1e-12,
                                       err_msg=name)
        # The std comes from a difference of sums of squares: where one sum is taken about a
        # reference far from the samples (a frame where the band just left the pixel), rounding
        # leaves ~16 ε ΔT² in the variance, ΔT ≤ the scene's span: √(16 ε)·T_max in the std.
        bound = np.sqrt(16 * np.finfo(float).eps) * float(alone.tensor_max.max())
        np.testing.assert_allclose(m.tensor_std, alone.tensor_std, rtol=1e-9, atol=bound)
        assert m.t_start == alone.t_start and m.n_frames == alone.n_frames


class _FrameByFrame(FrameStack):
    """The same stack, without blocks: the compiled engine takes it one frame per call."""

    def block_unchecked(self, start, stop, region=None):
        return None


def test_blocks_of_frames_give_the_frame_by_frame_result(monkeypatch):
    # A stored stack is integrated in blocks of consecutive frames (one kernel call each);
    # windows that cross block boundaries, start mid-block or leave gaps between them give
    # what frame-by-frame calls give (a scene of generated frames, not stacked: STACK_BYTES 0).
    from radiosim import frame_reading, integrator
    from radiosim.camera import measure_many
    from radiosim.kernels.merging import FRAME_BLOCK

    monkeypatch.setattr(frame_reading, "STACK_BYTES", 0)

    rng = np.random.default_rng(11)
    dx, dt = 1e-6, 1e-6
    stack = rng.uniform(290.0, 1200.0, (3 * FRAME_BLOCK, 30, 40)).astype(np.float32)
    nist = Camera.preset("nist-ir").with_pixel_pitch(4e-6)
    cases = [(Camera.linear_ideal(3e-6), 5 * dt, 0.0), (nist, 30.5 * dt, 3.25 * dt),
             (Camera.linear_ideal(3e-6), 4 * dt, 40 * dt), (nist, 2 * dt, 45 * dt)]
    blocks = measure_many(FrameStack(stack, dt=dt, dx=dx), cases, rng=3)
    frames = measure_many(_FrameByFrame(stack, dt=dt, dx=dx), cases, rng=3)
    for a, b in zip(blocks, frames):
        np.testing.assert_array_equal(a.tensor_max, b.tensor_max)
        for name in ("apparent_temperature", "tensor_mean", "signal_mean", "tensor_std"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-12,
                                       atol=0, err_msg=name)


def test_a_bad_sample_in_a_block_of_frames_names_its_frame():
    stack = np.full((40, 20, 20), 300.0, dtype=np.float32)
    stack[21, 7, 12] = np.nan
    scene = FrameStack(stack, dt=1e-6, dx=1e-6)
    assert scene.block_unchecked(16, 32) is not None
    with pytest.raises(RadiosimError, match="frame 21: temperature at row 7, column 12 is NaN"):
        Camera.linear_ideal(2e-6).measure(scene, 30e-6, t_start=0.0)


def test_frame_runs():
    from radiosim.kernels.merging import frame_runs as _runs

    assert _runs([0, 1, 2, 3, 4, 7, 8, 20], 3) == [(0, 3), (3, 5), (7, 9), (20, 21)]
    assert _runs([], 4) == []


def test_frames_no_window_of_a_group_holds_are_not_read():
    # A frame between two windows of one footprint group (read for another group) is not
    # checked for that group, in blocks as frame by frame: a NaN there is not an error.
    from radiosim.integrator import Job, integrate_many

    dt = dx = 1e-6
    stack = np.full((40, 20, 20), 300.0)
    stack[5, 15, 15] = np.nan
    whole = FootprintIntegrator(axis_footprints(20, dx, 2e-6, 1.0, 10**6),
                                axis_footprints(20, dx, 2e-6, 1.0, 10**6))
    corner = FootprintIntegrator(axis_footprints(20, dx, 2e-6, 1.0, 2),
                                 axis_footprints(20, dx, 2e-6, 1.0, 2))
    linear = LinearResponse()
    jobs = [Job(whole, Window(0.0, 2 * dt), linear), Job(whole, Window(20 * dt, 2 * dt), linear),
            Job(corner, Window(0.0, 22 * dt), linear)]
    for scene in (FrameStack(stack, dt=dt, dx=dx), _FrameByFrame(stack, dt=dt, dx=dx)):
        results = integrate_many(scene, jobs)
        np.testing.assert_array_equal(results[0].mean, 300.0)


def test_with_two_responses_the_earliest_bad_frame_is_named():
    # One footprint group, two kernel passes (linear, Planck): frame 3 is above the Planck
    # table, frame 5 has a NaN; frame 3 is named, in blocks as frame by frame.
    from radiosim.integrator import Job, integrate_many
    from radiosim.response import PlanckResponse

    dt = dx = 1e-6
    stack = np.full((20, 12, 12), 600.0)
    stack[3, 4, 4] = 2000.0
    stack[5, 7, 7] = np.nan
    group = FootprintIntegrator(axis_footprints(12, dx, 2e-6, 1.0, 10**6),
                                axis_footprints(12, dx, 2e-6, 1.0, 10**6))
    planck = PlanckResponse((3.8e-6, 5.1e-6), 1.0, temperature_range=(200.0, 1500.0))
    jobs = [Job(group, Window(0.0, 10 * dt), LinearResponse()),
            Job(group, Window(0.0, 10 * dt), planck)]
    for scene in (FrameStack(stack, dt=dt, dx=dx), _FrameByFrame(stack, dt=dt, dx=dx)):
        with pytest.raises(RadiosimError, match="frame 3: temperature 2000 K"):
            integrate_many(scene, jobs)


def test_a_linear_and_a_radiometric_job_share_one_pass_with_the_results_of_two(monkeypatch):
    # One footprint group, a linear and a Planck job: one kernel pass per block forms the
    # moments and the signal (the Planck pass first, keeping its moments below the table);
    # the results are those of two passes (linear moments, then the signal) bit for bit, also
    # for pixel rows with samples below the table (150 K < 200 K), whose signal numpy redoes.
    from radiosim.integrator import Job, integrate_many
    from radiosim.kernels import launch
    from radiosim.kernels.merging import FootprintGroup
    from radiosim.response import PlanckResponse

    dt = dx = 1e-6
    stack = 400.0 + 500.0 * np.random.default_rng(3).random((12, 18, 18))
    stack[2, 3, 5] = stack[7, 11, 2] = 150.0
    group = FootprintIntegrator(axis_footprints(18, dx, 2.5e-6, 1.0, 10**6),
                                axis_footprints(18, dx, 2.5e-6, 1.0, 10**6))
    planck = PlanckResponse((3.8e-6, 5.1e-6), 1.0, temperature_range=(200.0, 1500.0))
    jobs = [Job(group, Window(0.0, 9 * dt), LinearResponse()),
            Job(group, Window(dt, 10 * dt), planck)]
    calls = []
    merged = launch.accumulate_merged
    monkeypatch.setattr(launch, "accumulate_merged",
                        lambda *a, **k: calls.append(k["keep_moments"]) or merged(*a, **k))
    from radiosim.kernels import engines
    monkeypatch.setitem(engines.ENGINES, "compiled", dataclasses.replace(
        engines.ENGINES["compiled"], accumulate_merged=launch.accumulate_merged))

    def two_passes(passes, sample):  # the linear pass, then the signal's
        tables = [(response.signal_table(sample), members) for response, members in passes]
        return [(t, m, False) for k, (t, m) in enumerate(tables) if k == 0 or t is not None]

    for scene in (FrameStack(stack, dt=dt, dx=dx), _FrameByFrame(stack, dt=dt, dx=dx)):
        calls.clear()
        one = integrate_many(scene, jobs)
        fused = list(calls)  # frames both windows hold: one fused pass
        with monkeypatch.context() as patched:
            patched.setattr(FootprintGroup, "_ordered", staticmethod(two_passes))
            calls.clear()
            two = integrate_many(scene, jobs)
            assert not any(calls) and True in fused and len(calls) > len(fused)
        for a, b in zip(one, two):
            for name in ("mean", "std", "max", "signal_mean"):
                np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    # Windows that differ, in either order of the jobs: frames only one job's window holds
    # (samples below the table there; frame 0 above it, outside the Planck job's window) take
    # that job's pass alone, as before; no error for frame 0.
    stack[0, 6, 6] = 2000.0
    stack[9, 1, 1] = stack[10, 2, 2] = 150.0
    for jobs in ([Job(group, Window(0.0, 5 * dt), LinearResponse()),
                  Job(group, Window(2 * dt, 9 * dt), planck)],
                 [Job(group, Window(2 * dt, 9 * dt), planck),
                  Job(group, Window(0.0, 5 * dt), LinearResponse())]):
        for scene in (FrameStack(stack, dt=dt, dx=dx), _FrameByFrame(stack, dt=dt, dx=dx)):
            one = integrate_many(scene, jobs)
            with monkeypatch.context() as patched:
                patched.setattr(FootprintGroup, "_ordered", staticmethod(two_passes))
                two = integrate_many(scene, jobs)
            for a, b in zip(one, two):
                for name in ("mean", "std", "max", "signal_mean"):
                    np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_user_built_and_integrator_footprints_share_one_compiled_kernel():
    from radiosim import kernels
    from radiosim.integrator import AxisFootprints
    from radiosim.kernels.rows import accumulate_kernel

    rows = axis_footprints(30, 1.0, 3.0, 1.0, 10**6)
    built = AxisFootprints(np.array(rows.source), np.array(rows.weight), np.array(rows.starts))
    frame = np.full((30, 30), 300.0)
    kernels.pixel_mean(frame, rows, rows)
    before = len(accumulate_kernel.signatures)
    kernels.pixel_mean(frame, built, built)
    assert len(accumulate_kernel.signatures) == before


def test_a_window_past_the_last_frame_is_stated_in_readable_units():
    # "3–8 µs … 0–5 µs", not "3e-06–8e-06 s … 0–5e-06 s".
    from radiosim.errors import RadiosimError
    from radiosim.integrator import frame_weights

    with pytest.raises(RadiosimError) as caught:
        frame_weights(3e-6, 5e-6, 1e-6, 5)
    assert "window 3–8 µs" in str(caught.value) and "covers 0–5 µs, 5 frames" in str(caught.value)
    with pytest.raises(RadiosimError) as caught:
        frame_weights(0.0, 2.5e-3, 1e-4, 20)
    assert "window 0–2.5 ms" in str(caught.value) and "covers 0–2 ms" in str(caught.value)


def test_frames_made_one_at_a_time_are_stacked_into_blocks_with_the_same_bits(monkeypatch):
    # A scene that makes its frames one at a time gets small frames stacked into blocks (one
    # kernel call each): the same bits as one call per frame.
    import radiosim.frame_reading as frame_reading
    import radiosim.integrator as integrator
    from radiosim.camera import measure_many

    rng = np.random.default_rng(5)
    stack = rng.uniform(290.0, 1200.0, (150, 12, 15))
    scene = _FrameByFrame(stack, dt=1e-6, dx=1e-6)
    nist = Camera.preset("nist-ir").with_pixel_pitch(4e-6)
    linear = Camera.linear_ideal(3e-6)  # one camera, one response: one kernel pass
    cases = [(linear, 140e-6, 0.0), (linear, 7.5e-6, 3e-6), (nist, 20e-6, 130e-6)]
    calls = []
    engine = integrator.get_engine(None)
    monkeypatch.setattr(integrator, "get_engine", lambda name: dataclasses.replace(
        engine, accumulate_merged=lambda *a, **k: calls.append(a[0].shape) or
        engine.accumulate_merged(*a, **k)))
    stacked = measure_many(scene, cases, rng=3)
    assert max(len(shape) for shape in calls) == 3 and len(calls) < 10
    calls.clear()
    monkeypatch.setattr(frame_reading, "STACK_BYTES", 0)  # every frame alone
    alone = measure_many(scene, cases, rng=3)
    assert len(calls) > 150 and all(len(shape) == 2 for shape in calls)
    for a, b in zip(stacked, alone):
        for name in ("apparent_temperature", "tensor_mean", "signal_mean", "tensor_std",
                     "tensor_max", "counts", "electrons"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), name)


def test_only_frames_that_differ_in_temperature_alone_are_stacked():
    from radiosim.frame_reading import stacked as _stacked
    from radiosim.scenes.base import SceneFrame

    t = np.zeros((2, 3))
    grey = np.full((2, 3), 0.5)
    frames = [SceneFrame(t + k, 0.9, index=k) for k in range(4)]
    frames += [SceneFrame(t, 0.9, index=5), SceneFrame(t, 0.8, index=6),  # a gap; ε changes
               SceneFrame(t, grey, index=7), SceneFrame(t, grey[:], index=8),  # one map's views
               SceneFrame(t, 1.0, regions=np.zeros((2, 3), int), region_emissivity={0: 1.0},
                          index=9), SceneFrame(t, 1.0, index=10),
               SceneFrame(t, 1.0, index=11, reflected_temperature=300.0)]
    out = [(f.index, np.shape(temperature), n) for f, temperature, n in _stacked(frames)]
    assert out == [(0, (4, 2, 3), 4), (5, (2, 3), 1), (6, (2, 3), 1), (7, (2, 2, 3), 2),
                   (9, (2, 3), 1), (10, (2, 3), 1), (11, (2, 3), 1)]
    first = next(iter(_stacked(frames[:4])))[1]
    np.testing.assert_array_equal(first[:, 0, 0], [0, 1, 2, 3])


def test_slow_frames_are_read_ahead_in_batches_in_order_and_in_full():
    # A scene's frames larger than INLINE_BYTES are read ahead on a worker thread after the
    # first, in batches; small ones (the kernel's work per frame tiny) are read on the calling
    # thread however slow. Either way: every frame, once, in order, the same as read here.
    import threading
    import time

    from radiosim.frame_reading import INLINE_BYTES, prefetched, read_ahead

    class Slow(FrameStack):
        readers = {}

        def sample_unchecked(self, k, region=None):
            began = time.perf_counter()
            while time.perf_counter() - began < 3e-4:
                pass
            self.readers[k] = threading.current_thread()
            return super().sample_unchecked(k, region)

    for rows, cols, ahead in ((4, 5, False), (3 + INLINE_BYTES // (8 * 40), 40, True)):
        frames = np.arange(37 * rows * cols, dtype=float).reshape(37, rows, cols) + 300.0
        stack = Slow(frames, 1e-6, 1e-6)
        region = (slice(1, rows - 1), slice(0, cols))
        assert (8 * (rows - 2) * cols > INLINE_BYTES) is ahead
        indices = list(range(2, 37))
        expected = frames[2:, 1:rows - 1]
        for read in (read_ahead(stack, indices, region),
                     prefetched(stack, indices, region, checked=False, batch=4),
                     prefetched(stack, indices, region, batch=1)):
            Slow.readers = {}
            got = list(read)
            assert [f.index for f in got] == indices
            assert np.array_equal(np.stack([f.temperature for f in got]), expected)
            if read.__name__ == "read_ahead":
                here = [Slow.readers[k] is threading.current_thread() for k in indices]
                assert here == ([True] + [False] * 34 if ahead else [True] * 35)


def test_a_process_given_one_kernel_thread_reads_its_frames_on_that_thread():
    """A single-thread Dask worker (NUMBA_NUM_THREADS=1, as radiosim's local clusters set it
    with as many workers as cores) reads large frames on its one thread: no read-ahead thread
    takes a second core."""
    import threading

    import numba

    from radiosim.frame_reading import INLINE_BYTES, read_ahead

    rows, cols = 3 + INLINE_BYTES // (8 * 40), 40
    frames = np.arange(9 * rows * cols, dtype=float).reshape(9, rows, cols) + 300.0
    readers = []

    class Watched(FrameStack):
        def sample_unchecked(self, k, region=None):
            readers.append(threading.current_thread())
            return super().sample_unchecked(k, region)

    stack = Watched(frames, 1e-6, 1e-6)
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        got = list(read_ahead(stack, range(9), (slice(0, rows), slice(0, cols))))
    finally:
        numba.set_num_threads(before)
    assert [f.index for f in got] == list(range(9))
    assert all(t is threading.current_thread() for t in readers)


def test_a_frame_that_cannot_be_read_ahead_fails_after_the_frames_before_it():
    # Read ahead in batches, an unreadable frame raises its own error after every frame
    # before it was delivered, whatever the batch: the same as read one by one.
    from radiosim.frame_reading import prefetched

    class Broken(FrameStack):
        def sample_unchecked(self, k, region=None):
            if k == 6:
                raise RadiosimError(f"frame {k}: unreadable")
            return super().sample_unchecked(k, region)

    stack = Broken(np.full((12, 3, 4), 300.0), 1e-6, 1e-6)
    region = (slice(0, 3), slice(0, 4))
    for batch in (1, 4, 5, 12):
        got = []
        with pytest.raises(RadiosimError, match="frame 6: unreadable"):
            for frame in prefetched(stack, range(12), region, checked=False, batch=batch):
                got.append(frame.index)
        assert got == [0, 1, 2, 3, 4, 5]

"""The compiled streaming kernels against their numpy references (and those against the
integrator's arithmetic, the radiance table and the exact quadrature)."""

import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from radiosim import kernels
from radiosim.errors import RadiosimError
from radiosim.integrator import AxisFootprints, axis_footprints
from radiosim.kernels import layout, packing, radiance
from radiosim.kernels import (
    STATUS_BELOW_TABLE,
    STATUS_OK,
    SignalTable,
    accumulate,
    accumulate_reference,
    pixel_mean,
    pixel_mean_reference,
)
from radiosim.radiometry import BandRadianceTable, band_radiance
from radiosim.spectral import spectral_distribution

COMPILED_AT_IMPORT = sum(len(f.signatures) for f in kernels.dispatchers())

SCENE = (70, 90)  # scene samples (rows, columns)
T_SCALE = 1500.0  # [K], the scale of the temperatures below
WEIGHTS = (0.15, 0.35, 0.3, 0.2)  # a window with fractional first and last frames
RANGE = (200.0, 3000.0)  # radiance table range [K]
PER_OCTAVE = 32  # a coarse table: fast to build, evaluated exactly all the same

# (pitch [samples], fill factor, origin [samples]): integer and fractional footprints.
FOOTPRINTS = {
    "9 samples": (9.0, 1.0, 0.0),
    "3 samples": (3.0, 1.0, 0.0),
    "1 sample": (1.0, 1.0, 0.0),
    "7.3 samples": (7.3, 1.0, 0.0),
    "7.3 samples, fill 0.8": (7.3, 0.8, 0.0),
    "4.5 samples, fill 0.8, origin 2.7": (4.5, 0.8, 2.7),
}


def footprints(pitch, fill, origin, max_pixels=10**6):
    rows = axis_footprints(SCENE[0], 1.0, pitch, fill, max_pixels, origin)
    cols = axis_footprints(SCENE[1], 1.0, pitch, fill, max_pixels, origin)
    return rows, cols


def region_of(frame, rows, cols):
    """The frame region the integrator reads (a view: rows strided when columns are cut)."""
    return frame[rows.span, cols.span]


def scene_frames(dtype, n=len(WEIGHTS), seed=0, low=300.0, high=T_SCALE):
    rng = np.random.default_rng(seed)
    return rng.uniform(low, high, (n, *SCENE)).astype(dtype)


@pytest.fixture(scope="module")
def tables():
    """Radiance tables: the blackbody one, and one of a spectral emissivity."""
    curve = spectral_distribution([3e-6, 4.5e-6, 6e-6], [0.3, 0.8, 0.5], "test curve")
    return SignalTable.build(emissivity=[1.0, 0.6, curve], temperature_range=RANGE,
                                     per_octave=PER_OCTAVE)


def responses(tables, shape, seed=1):
    """Every emissivity form, on a region of ``shape``."""
    rng = np.random.default_rng(seed)
    grey_map = rng.uniform(0.2, 1.0, shape)
    index = rng.integers(0, 3, shape).astype(np.uint8)
    blackbody = SignalTable(tables.tables[0], tables.exact[0])
    return {
        "none": None,
        "grey scalar": blackbody.with_maps(grey=0.85),
        "grey map": blackbody.with_maps(grey=grey_map),
        "spectral": SignalTable(tables.tables[2], tables.exact[2]),
        "tables + index": tables.with_maps(index=index),
        "tables + index, grey 0.7": tables.with_maps(index=index, grey=0.7),
        "tables + index + grey map": tables.with_maps(index=index, grey=grey_map),
    }


def integrate(frames, rows, cols, response, mean_fn, accumulate_fn):
    """One window, as the integrator streams it: reference from the first frame, then one
    accumulate per frame."""
    region = region_of(frames[0], rows, cols)
    reference = mean_fn(region, rows, cols)
    shape = reference.shape
    dev, sq, signal = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    tmax = np.full(shape, -np.inf)
    statuses = []
    for k, (frame, weight) in enumerate(zip(frames, WEIGHTS)):
        statuses.append(accumulate_fn(region_of(frame, rows, cols), rows, cols, weight,
                                      reference, dev, sq, tmax,
                                      None if response is None else signal, response,
                                      frame_index=k))
    return reference, dev, sq, tmax, signal, statuses


def assert_same_statistics(kernel, numpy):
    reference, dev, sq, tmax, signal, _ = kernel
    reference0, dev0, sq0, tmax0, signal0, _ = numpy
    np.testing.assert_allclose(reference, reference0, rtol=1e-12, atol=0)
    # dev is a small correction of a mean of order T: it agrees to 1e-12 of T, and the mean
    # c + dev to 1e-12 relative.
    np.testing.assert_allclose(dev, dev0, rtol=0, atol=1e-12 * T_SCALE)
    np.testing.assert_allclose(reference + dev, reference0 + dev0, rtol=1e-12, atol=0)
    np.testing.assert_allclose(sq, sq0, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(tmax, tmax0)
    np.testing.assert_allclose(signal, signal0, rtol=1e-12, atol=0)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", FOOTPRINTS)
def test_kernels_agree_with_the_numpy_reference(name, dtype, tables):
    rows, cols = footprints(*FOOTPRINTS[name])
    frames = scene_frames(dtype)
    shape = region_of(frames[0], rows, cols).shape
    forms = responses(tables, shape)
    # Every footprint with the linear response and a grey body; every emissivity form on the
    # integer and the fractional paper-like footprints.
    chosen = forms if name in ("9 samples", "7.3 samples, fill 0.8") else {
        k: forms[k] for k in ("none", "grey scalar")}
    for form, response in chosen.items():
        kernel = integrate(frames, rows, cols, response, pixel_mean, accumulate)
        numpy = integrate(frames, rows, cols, response, pixel_mean_reference,
                          accumulate_reference)
        assert kernel[-1] == numpy[-1] == [STATUS_OK] * len(WEIGHTS), form
        assert_same_statistics(kernel, numpy)
        if response is None:
            assert not kernel[4].any()


def test_reference_is_the_integrators_arithmetic():
    """The numpy reference against FootprintIntegrator (and the naive p × p × n tensor)."""
    from radiosim.integrator import FootprintIntegrator

    for pitch, fill, origin in FOOTPRINTS.values():
        rows, cols = footprints(pitch, fill, origin)
        integrator = FootprintIntegrator(rows, cols)
        frames = scene_frames(np.float64)
        reference, dev, sq, tmax, _, _ = integrate(frames, rows, cols, None,
                                                   pixel_mean_reference, accumulate_reference)
        pieces = [integrator.expand(f[integrator.region]) for f in frames]
        c = integrator.pixel_mean(pieces[0])
        np.testing.assert_allclose(reference, c, rtol=1e-13)
        mean = sum(w * integrator.pixel_mean(p) for w, p in zip(WEIGHTS, pieces))
        np.testing.assert_allclose(reference + dev, mean, rtol=1e-12)
        peak = np.max([integrator.pixel_max(p) for p in pieces], axis=0)
        np.testing.assert_array_equal(tmax, peak)
    # 9 × 9 pixels, equal frame weights: the paper's tensors.
    rows, cols = footprints(9.0, 1.0, 0.0)
    frames = scene_frames(np.float64)
    sums = integrate(frames, rows, cols, None, pixel_mean, accumulate)
    block = frames[:, :63, :90].reshape(len(WEIGHTS), 7, 9, 10, 9)
    weights = np.asarray(WEIGHTS)[:, None, None, None, None]
    mean = (block * weights).sum(axis=0).mean(axis=(1, 3))
    np.testing.assert_allclose(sums[0] + sums[1], mean, rtol=1e-12)
    np.testing.assert_array_equal(sums[3], block.max(axis=(0, 2, 4)))


def test_signal_is_the_table_times_the_emissivity(tables):
    """One-sample pixels: the kernel's signal is the table's radiance × the grey factors."""
    rows, cols = footprints(1.0, 1.0, 0.0)
    frame = scene_frames(np.float64, n=1)[0]
    forms = responses(tables, frame.shape)
    table = tables.tables[0]
    for form, expected in (("grey scalar", 0.85 * table(frame)),
                           ("grey map", table(frame) * forms["grey map"].grey),
                           ("spectral", tables.tables[2](frame))):
        reference = pixel_mean(frame, rows, cols)
        shape = reference.shape
        dev, sq, signal, tmax = np.zeros(shape), np.zeros(shape), np.zeros(shape), np.zeros(shape)
        accumulate(frame, rows, cols, 1.0, reference, dev, sq, tmax, signal, forms[form])
        np.testing.assert_allclose(signal, expected, rtol=1e-14, err_msg=form)


def test_memory_mapped_frames(tmp_path, tables):
    """A read-only memmap of float32 frames, integrated over a region (a strided view)."""
    path = tmp_path / "stack.npy"
    np.save(path, scene_frames(np.float32))
    frames = np.load(path, mmap_mode="r")
    rows, cols = footprints(4.5, 0.8, 2.7)
    response = responses(tables, region_of(frames[0], rows, cols).shape)["grey map"]
    kernel = integrate(frames, rows, cols, response, pixel_mean, accumulate)
    numpy = integrate(np.asarray(frames), rows, cols, response, pixel_mean_reference,
                      accumulate_reference)
    assert_same_statistics(kernel, numpy)


def test_thread_count_does_not_change_the_result():
    # Every thread numba allows (given: a launch this small would run on one by default).
    import numba

    threads = numba.config.NUMBA_NUM_THREADS
    if threads < 2:
        pytest.skip("one thread on this machine")
    rows, cols = footprints(7.3, 1.0, 0.0)
    frames = scene_frames(np.float32)
    one = integrate(frames, rows, cols, None, lambda *a, **k: pixel_mean(*a, **k, threads=1),
                    lambda *a, **k: accumulate(*a, **k, threads=1))
    every = integrate(frames, rows, cols, None,
                      lambda *a, **k: pixel_mean(*a, **k, threads=threads),
                      lambda *a, **k: accumulate(*a, **k, threads=threads))
    for a, b in zip(one[:5], every[:5]):
        np.testing.assert_array_equal(a, b)


def test_run_blocks_waits_for_every_block_before_it_raises():
    """A block's exception reaches the caller only once every block has finished (they write
    the caller's arrays); results come in block order."""
    import threading
    import time

    from radiosim.kernels import run_blocks

    done = []
    lock = threading.Lock()

    def kernel(b, fail):
        if b == fail:
            raise ValueError(f"block {b}")
        time.sleep(0.05 * b)
        with lock:
            done.append(b)
        return b * b

    assert run_blocks(kernel, 4, -1) == [0, 1, 4, 9]
    done.clear()
    with pytest.raises(ValueError, match="block 0"):
        run_blocks(kernel, 4, 0)
    assert sorted(done) == [1, 2, 3]  # the others had finished when it was raised


def test_float32_frames_are_read_in_place():
    frame = scene_frames(np.float32, n=1)[0]
    rows, cols = footprints(7.3, 0.8, 0.0)
    region = region_of(frame, rows, cols)
    assert not region.flags.c_contiguous
    flat, row_length = layout.rows_of(region)
    assert flat.dtype == np.float32 and np.shares_memory(flat, frame)
    assert row_length == SCENE[1]


@pytest.mark.parametrize("bad, what", [(np.nan, "is NaN; temperatures must be finite"),
                                       (0.0, "is 0 K; temperatures must be > 0 K"),
                                       (-12.5, "is -12.5 K; temperatures must be > 0 K"),
                                       (np.inf, "is inf; temperatures must be finite")])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_bad_samples_raise_naming_frame_row_and_column(bad, what, dtype, tables):
    rows, cols = footprints(4.5, 0.8, 2.7)
    frames = scene_frames(dtype)
    (r0, r1), (c0, c1) = (rows.source[[5, 20]], cols.source[[7, 30]])
    frames[2, r0, c0] = bad
    frames[2, r1, c1] = bad
    response = responses(tables, region_of(frames[0], rows, cols).shape)["tables + index"]
    message = (f"frame 2: temperature at row {r0}, column {c0} {what}")
    for mean_fn, accumulate_fn in ((pixel_mean, accumulate),
                                   (pixel_mean_reference, accumulate_reference)):
        for signal in (None, response):
            with pytest.raises(RadiosimError, match="2 bad sample") as error:
                integrate(frames, rows, cols, signal, mean_fn, accumulate_fn)
            assert message in str(error.value)
    with pytest.raises(RadiosimError, match=f"frame 9: temperature at row {r0}, column {c0}"):
        pixel_mean(region_of(frames[2], rows, cols), rows, cols, frame_index=9)


@pytest.mark.parametrize("name", ["3 samples", "4.5 samples, fill 0.8, origin 2.7"])
def test_frames_with_samples_below_the_table_match_the_reference(name, tables):
    """Cold samples do not raise: their pixel rows go through the numpy path, which integrates
    them exactly (band_radiance), and the other pixel rows keep the kernel's values."""
    rows, cols = footprints(*FOOTPRINTS[name])
    frames = scene_frames(np.float32)
    frames[1, 6:9, 9:12] = 150.0  # below the table (200 K)
    frames[1, 30, 40] = 120.0
    frames[3, 50:52, 20] = 199.0
    shape = region_of(frames[0], rows, cols).shape
    for form in ("grey scalar", "tables + index + grey map"):
        response = responses(tables, shape)[form]
        kernel = integrate(frames, rows, cols, response, pixel_mean, accumulate)
        numpy = integrate(frames, rows, cols, response, pixel_mean_reference,
                          accumulate_reference)
        assert kernel[-1] == numpy[-1] == [0, STATUS_BELOW_TABLE, 0, STATUS_BELOW_TABLE]
        assert_same_statistics(kernel, numpy)


def test_samples_below_the_table_get_the_exact_quadrature(tables):
    rows, cols = footprints(3.0, 1.0, 0.0)
    frames = scene_frames(np.float32)
    frames[1, 6:9, 9:12] = 150.0  # one whole pixel, (2, 3), below the table (200 K)
    frames[1, 30, 40] = 120.0  # one sample of pixel (10, 13)
    shape = region_of(frames[0], rows, cols).shape
    # Frame 1's share of the cold pixel is the exact in-band radiance of 150 K × 0.85.
    response = responses(tables, shape)["grey scalar"]
    region = region_of(frames[1], rows, cols)
    reference = pixel_mean(region, rows, cols)
    dev, sq, signal, tmax = (np.zeros(reference.shape) for _ in range(4))
    assert accumulate(region, rows, cols, 0.5, reference, dev, sq, tmax, signal,
                      response) == STATUS_BELOW_TABLE
    exact = band_radiance(150.0, **tables.exact[0])
    assert signal[2, 3] == pytest.approx(0.5 * 0.85 * exact, rel=1e-12)
    cold_pixel = frames[1, 30:33, 39:42].astype(float)
    radiance = np.where(cold_pixel < RANGE[0], band_radiance(cold_pixel, **tables.exact[0]),
                        tables.tables[0](np.maximum(cold_pixel, RANGE[0])))
    assert signal[10, 13] == pytest.approx(0.5 * 0.85 * radiance.mean(), rel=1e-12)


def test_a_nan_reference_raises():
    rows, cols = footprints(9.0, 1.0, 0.0)
    frame = scene_frames(np.float32, n=1)[0]
    reference = pixel_mean(frame, rows, cols)
    reference[2, 3] = np.nan
    out = [np.zeros(reference.shape) for _ in range(3)]
    with pytest.raises(RadiosimError, match="reference .* must be finite"):
        accumulate(frame, rows, cols, 1.0, reference, *out)


def test_samples_above_the_table_raise(tables):
    rows, cols = footprints(9.0, 1.0, 0.0)
    frames = scene_frames(np.float32)
    frames[3, 40, 50] = 3500.0
    response = responses(tables, region_of(frames[0], rows, cols).shape)["grey map"]
    for mean_fn, accumulate_fn in ((pixel_mean, accumulate),
                                   (pixel_mean_reference, accumulate_reference)):
        with pytest.raises(RadiosimError, match="frame 3: temperature 3500 K at row 40, column "
                           "50 is outside the radiance table's range 200–3000 K"):
            integrate(frames, rows, cols, response, mean_fn, accumulate_fn)
    # Without a signal, hot samples are fine.
    integrate(frames, rows, cols, None, pixel_mean, accumulate)


def test_bad_table_index_raises(tables):
    rows, cols = footprints(9.0, 1.0, 0.0)
    frames = scene_frames(np.float32)
    response = responses(tables, region_of(frames[0], rows, cols).shape)["tables + index"]
    index = response.index.copy()
    index[12, 34] = 7
    for accumulate_fn in (accumulate, accumulate_reference):
        with pytest.raises(RadiosimError, match="table index 7 at row 12, column 34 is not an "
                           "entry"):
            integrate(frames, rows, cols, response.with_maps(index=index), pixel_mean,
                      accumulate_fn)


def test_table_packing(tables):
    assert tables.n_entries == 3
    # The blackbody table is packed once: two tables of 32 intervals per octave, over
    # 200–3000 K 125 intervals (200–3008 K), plus 12 past each end (grid 152–3776 K).
    assert [t.intervals for t in tables.tables] == [149, 149, 149]
    packed = packing.pack(tables)  # the compiled engine's format of the signal table
    assert packed.coef.shape == (2 * 149 * 4,)
    assert packed.offset.tolist() == [0, 149]
    assert packed.entry_table.tolist() == [0, 0, 1]
    assert packed.entry_grey.tolist() == [1.0, 0.6, 1.0]
    table = BandRadianceTable(temperature_range=RANGE, per_octave=PER_OCTAVE)
    rows, cols = footprints(9.0, 1.0, 0.0)
    frames = scene_frames(np.float64)
    with pytest.raises(RadiosimError, match="2 radiance table entries need an index map"):
        integrate(frames, rows, cols, SignalTable([table, table]), pixel_mean,
                  accumulate)
    packed = SignalTable(table)  # no exact radiance: cold samples raise
    frames[:, 0, 0] = 150.0
    with pytest.raises(RadiosimError, match="no exact radiance"):
        integrate(frames, rows, cols, packed, pixel_mean, accumulate)


@pytest.mark.parametrize("weight", [0.0, -0.1, np.nan])
def test_pieces_of_no_weight_are_refused(weight):
    # A piece reads its sample: one of weight 0 would read it unchecked (NaN, out of table).
    rows, cols = footprints(9.0, 1.0, 0.0)
    weights = cols.weight.copy()
    weights[4] = weight
    broken = AxisFootprints(cols.source, weights, cols.starts)
    frames = scene_frames(np.float64)
    with pytest.raises(RadiosimError, match="every piece's weight must be a finite number > 0"):
        integrate(frames, rows, broken, None, pixel_mean, accumulate)


def test_footprints_of_any_layout_agree_with_the_reference(tables):
    # The integrator's footprints are regular (a pixel's interior pieces are whole samples of
    # one weight, on consecutive slots) and reduce to pixels by a short path; footprints built
    # otherwise (uneven weights, a pixel reading a sample twice) take the general one.
    rows, cols = footprints(4.5, 0.8, 2.7)
    assert layout.kernel_axis(cols, "column").slots[-1] == 2
    assert layout.kernel_axis(footprints(9.0, 1.0, 0.0)[1], "column").slots[-1] == 3
    rng = np.random.default_rng(8)
    uneven = AxisFootprints(cols.source, rng.uniform(0.05, 0.3, cols.source.size), cols.starts)
    twice = AxisFootprints(np.sort(np.append(cols.source, cols.source[[3, 11]])),
                           rng.uniform(0.05, 0.3, cols.source.size + 2), cols.starts)
    frames = scene_frames(np.float32)
    for broken in (uneven, twice):
        assert layout.kernel_axis(broken, "column").slots[-1] == 0
        response = responses(tables, region_of(frames[0], rows, broken).shape)["grey map"]
        for signal in (None, response):
            kernel = integrate(frames, rows, broken, signal, pixel_mean, accumulate)
            numpy = integrate(frames, rows, broken, signal, pixel_mean_reference,
                              accumulate_reference)
            assert_same_statistics(kernel, numpy)


def test_importing_compiles_nothing():
    # Counted when this module was imported (collection), before any test ran.
    assert COMPILED_AT_IMPORT == 0


def test_importing_and_launching_leave_the_environment_as_it_was():
    # Neither importing radiosim (and its kernels) nor a kernel launch changes os.environ
    # (no thread-layer settings are made on the user's behalf).
    code = (
        "import os; before = dict(os.environ); import radiosim, radiosim.kernels\n"
        "imported = dict(os.environ)\n"
        "import numpy as np\n"
        "from radiosim.integrator import axis_footprints\n"
        "f = axis_footprints(3, 1.0, 3.0, 1.0, 10**6)\n"
        "radiosim.kernels.pixel_mean(np.full((3, 3), 300.0), f, f)\n"
        "print(imported == before, dict(os.environ) == before)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["True", "True"]


def test_cubic_rows_match_numpy_horner():
    # The compiled cubics (eight at a time through _cubic8's shuffles, then one by one) are
    # numpy's Horner steps, in the same order, each multiply-add fused (rounded once instead
    # of twice): they differ from numpy's by at most a rounding of each step, ≤ 4 ε times the
    # sum of the terms' magnitudes.
    rng = np.random.default_rng(7)
    coef = rng.normal(size=(50, 4))
    for n in (1, 8, 13, 64, 67):
        interval = rng.integers(0, 50, n).astype(np.uint64)
        position = rng.uniform(0, 1, n)
        out = np.empty(n)
        radiance.cubic_from_python(coef.reshape(-1), interval, position, out, n)
        a, b, c, d = coef[interval.astype(np.intp)].T
        numpy = ((a * position + b) * position + c) * position + d
        scale = (np.abs(a) * position**3 + np.abs(b) * position**2 + np.abs(c) * position
                 + np.abs(d))
        assert np.all(np.abs(out - numpy) <= 4 * np.finfo(float).eps * scale)
        assert np.any(out != numpy) or n < 13  # fused: not numpy's roundings


# -- several frames per call -----------------------------------------------------------------

def merge_frames(block, rows, cols, response, weight, signal_weight, per_call,
                 engine=kernels.ENGINES["compiled"]):
    """Merge the frames of ``block`` into two jobs, ``per_call`` frames per call."""
    first = region_of(block[0], rows, cols)
    reference = engine.pixel_mean(first, rows, cols)
    members = kernels.Members(2, reference.shape)
    statuses = []
    for k in range(0, len(block), per_call):
        part = block[k:k + per_call, rows.span, cols.span]
        one = per_call == 1
        statuses.append(engine.accumulate_merged(
            part[0] if one else part, rows, cols, reference, members,
            weight[k] if one else weight[k:k + per_call],
            signal_weight[k] if one else signal_weight[k:k + per_call], response,
            frame_index=k))
    return reference, members, statuses


@pytest.mark.parametrize("name", ["9 samples", "4.5 samples, fill 0.8, origin 2.7"])
def test_a_block_of_frames_merges_as_frame_by_frame(name, tables):
    # Several frames in one call go through the same kernel one after the other, with each
    # frame's weights and the counts of the frames before it: bit for bit the frame-by-frame
    # result, cold samples (the numpy path, mid-block) included.
    rows, cols = footprints(*FOOTPRINTS[name])
    block = scene_frames(np.float32, n=11, seed=3)
    # Below the table (200 K), in the middle of the block, for rows of either thread's half
    # (each half goes on alone after a frame the other stopped at).
    block[4, 6:9, 9:12] = 150.0
    block[2, 50, 30] = 180.0
    block[7, 55:57, 20] = 150.0
    rng = np.random.default_rng(4)
    weight = rng.uniform(0.0, 0.2, (11, 2))
    weight[:3, 1] = 0.0  # the second job's window starts at frame 3
    response = responses(tables, region_of(block[0], rows, cols).shape)["grey map"]
    for table in (None, response):
        signal_weight = weight if table is not None else np.zeros_like(weight)
        one = merge_frames(block, rows, cols, table, weight, signal_weight, 1)
        many = merge_frames(block, rows, cols, table, weight, signal_weight, 11)
        np.testing.assert_array_equal(one[0], many[0])
        for name_ in ("mean", "m2", "max", "signal", "count"):
            np.testing.assert_array_equal(getattr(one[1], name_), getattr(many[1], name_))
        expected = STATUS_BELOW_TABLE if table is not None else STATUS_OK
        assert one[2][2] == one[2][4] == one[2][7] == many[2][0] == expected


def test_a_bad_sample_in_a_block_names_its_frame(tables):
    rows, cols = footprints(3.0, 1.0, 0.0)
    block = scene_frames(np.float64, n=6, seed=5)
    block[4, 10, 20] = np.nan
    block[5, 60, 7] = np.nan  # later, in the other thread's half: the earlier frame is named
    weight = np.full((6, 1), 1 / 6)
    first = region_of(block[0], rows, cols)
    reference = pixel_mean(first, rows, cols)
    members = kernels.Members(1, reference.shape)
    with pytest.raises(RadiosimError, match="frame 14: temperature at row 10, column 20 is NaN"):
        kernels.accumulate_merged(block[:, rows.span, cols.span], rows, cols, reference,
                                  members, weight, weight, None, frame_index=10)


def test_block_weights_need_one_row_per_frame():
    rows, cols = footprints(3.0, 1.0, 0.0)
    block = scene_frames(np.float64, n=3)[:, rows.span, cols.span]
    reference = pixel_mean(block[0], rows, cols)
    members = kernels.Members(2, reference.shape)
    with pytest.raises(RadiosimError, match=r"weight must have shape \(2,\) for one frame or "
                                            r"\(3, 2\) for 3 frames"):
        kernels.accumulate_merged(block, rows, cols, reference, members, np.ones(2),
                                  np.ones((3, 2)))
    with pytest.raises(RadiosimError, match="non-empty 3-D stack"):
        kernels.accumulate_merged(block[:0], rows, cols, reference, members, np.ones((0, 2)),
                                  np.ones((0, 2)))


# -- engines ----------------------------------------------------------------------------------

def test_the_numpy_engine_merges_blocks_as_the_compiled_one(tables):
    # The numpy engine's merge (each frame's sums by accumulate_reference, Chan's update in
    # numpy) is the compiled merge's oracle: same moments to 1e-12 relative, maximum exactly.
    rows, cols = footprints(*FOOTPRINTS["4.5 samples, fill 0.8, origin 2.7"])
    block = scene_frames(np.float32, n=6, seed=9)
    block[3, 6:9, 9:12] = 150.0  # below the table: the compiled engine's numpy path
    rng = np.random.default_rng(2)
    weight = rng.uniform(0.0, 0.2, (6, 2))
    weight[:2, 1] = 0.0
    shape = region_of(block[0], rows, cols).shape
    response = responses(tables, shape)["tables + index + grey map"]
    compiled = merge_frames(block, rows, cols, response, weight, weight, 6)
    numpy = merge_frames(block, rows, cols, response, weight, weight, 6,
                         kernels.ENGINES["numpy"])
    np.testing.assert_allclose(compiled[0], numpy[0], rtol=1e-12, atol=0)
    for name in ("mean", "m2", "signal", "count"):
        np.testing.assert_allclose(getattr(compiled[1], name), getattr(numpy[1], name),
                                   rtol=1e-12, atol=0)
    np.testing.assert_array_equal(compiled[1].max, numpy[1].max)
    assert compiled[2] == numpy[2] == [STATUS_BELOW_TABLE]


def test_the_engine_is_chosen_in_one_place(monkeypatch):
    from radiosim.kernels import engines

    monkeypatch.delenv("RADIOSIM_ENGINE", raising=False)
    monkeypatch.setattr(engines, "_selected", None)
    assert engines.get_engine().name == "compiled"
    monkeypatch.setenv("RADIOSIM_ENGINE", "numpy")
    assert engines.get_engine().name == "numpy"
    engines.set_engine("compiled")  # the process setting wins over the environment
    assert engines.get_engine().name == "compiled"
    assert engines.get_engine("numpy").accumulate is accumulate_reference  # an argument wins
    engines.set_engine(None)
    assert engines.get_engine().name == "numpy"
    monkeypatch.setenv("RADIOSIM_ENGINE", "gpu")
    with pytest.raises(RadiosimError, match="environment variable RADIOSIM_ENGINE: engine must "
                                            "be one of compiled, numpy, got 'gpu'"):
        engines.get_engine()
    with pytest.raises(RadiosimError, match="set_engine: engine must be one of"):
        engines.set_engine("cuda")


def test_kernel_cache_stamp_covers_every_kernel_source(tmp_path, monkeypatch):
    # numba stamps a cached function with its own file only; radiosim's locator adds a stamp
    # over all kernel sources, so a change to an inlined helper's file (here: a new size)
    # changes every kernel's stamp.
    import numba

    from radiosim.kernels import cache, rows

    folder = tmp_path / "kernels"
    folder.mkdir()
    (folder / "rows.py").write_text("x = 1\n")
    (folder / "intrinsics.py").write_text("y = 1\n")
    monkeypatch.setattr(cache, "KERNEL_SOURCES", (folder,))
    cache.source_stamp.cache_clear()
    before = cache.source_stamp()
    (folder / "intrinsics.py").write_text("y = 12\n")
    cache.source_stamp.cache_clear()
    assert cache.source_stamp() != before
    cache.source_stamp.cache_clear()
    monkeypatch.undo()
    cache.source_stamp.cache_clear()
    # The kernels' own locator is the stamped one, and numba's is inside it.
    locator = rows.accumulate_kernel._cache._impl.locator
    assert type(locator).__name__ == "_PackageStampLocator"
    assert locator.get_source_stamp()[1] == cache.source_stamp()
    # numba's warning that a result cannot be cached (NUMBA_OPT=0 leaves dynamic globals in the
    # kernels) reads the locator's source file: a warning naming rows.py, not an AttributeError.
    assert Path(locator._py_file) == Path(rows.__file__).resolve()
    impl = rows.accumulate_kernel._cache._impl
    result = SimpleNamespace(lifted=(), fndesc=SimpleNamespace(qualname="accumulate_kernel"),
                             library=SimpleNamespace(has_dynamic_globals=True))
    with pytest.warns(numba.NumbaWarning, match="Cannot cache compiled function") as caught:
        assert impl.check_cachable(result) is False
    assert Path(caught[0].filename) == Path(rows.__file__).resolve()


def test_cache_files_of_other_sources_are_removed_once_a_process_writes_there(tmp_path):
    # After an update (or a new install: new modification times) the first compile writes the
    # new sources' files; the files stamped for the old ones (or not stamped: radiosim before
    # the stamp was in the names) and older than the new sources are never read again, and go.
    # Anything else stays: a stale-stamped file written since (a run of the old version still
    # going), files of other modules, numba's temporary files, bytecode.
    import os

    from radiosim.kernels import cache, rows

    now = cache.source_stamp()[:10]
    old = "0123456789" if now != "0123456789" else "9876543210"
    cache_file = rows.accumulate_kernel._cache._cache_file  # numba's own names, these sources
    current = [cache_file._index_name, cache_file._data_name(1)]
    assert all(f"-{now}.py" in name for name in current)
    stale = [name.replace(now, old) for name in current] + [
        f"kernel.moving_terms_kernel-276-{old}.py312d.nbi",
        "bands._band_pass-104.py311.nbi", "bands._band_pass-104.py311.3.nbc"]
    kept = current + [current[0].replace(".py311", ".py312"),  # another Python, these sources
                      f"notakernel.f-12-{old}.py311.nbi",  # not a radiosim kernel module
                      f"{stale[0]}.tmp.3f2a", "rows.cpython-311.pyc", "notes.nbi"]
    for name in kept + stale:
        (tmp_path / name).write_text("x")
        os.utime(tmp_path / name, (1e9, 1e9))  # 2001: older than any source
    newer = f"rows.accumulate_kernel-226-{old}.py311.2.nbc"
    (tmp_path / newer).write_text("x")  # written now, after the sources
    assert sorted(p.name for p in cache.prune_stale(tmp_path)) == sorted(stale)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(kept + [newer])

    # The kernels' locator prunes a folder the first time this process writes into it only.
    class Inner:
        def ensure_cache_path(self):
            pass

        def get_cache_path(self):
            return str(tmp_path)

    locator = cache._PackageStampLocator(Inner())
    (tmp_path / stale[0]).write_text("x")
    os.utime(tmp_path / stale[0], (1e9, 1e9))
    locator.ensure_cache_path()
    assert not (tmp_path / stale[0]).exists()
    (tmp_path / stale[0]).write_text("x")
    os.utime(tmp_path / stale[0], (1e9, 1e9))
    locator.ensure_cache_path()  # the same folder again: left as it is
    assert (tmp_path / stale[0]).exists()


def test_an_engine_made_from_numpy_carries_every_pass_with_its_bits(monkeypatch):
    # An engine registered as a copy of the numpy one carries every hot pass of a nist-ir-psf
    # measurement, of a frame stack and of the built-in chip (the integrator, the image
    # stage's sub-bands and blur, the chip's moving terms), running no compiled code (every
    # compiled entry point is made to fail), with the numpy engine's bits.
    import dataclasses

    import radiosim as rs
    from radiosim.kernels import bands, engines, launch
    from radiosim.scenes import SegmentedChip
    from radiosim.scenes.segmented_chip import scene as chip_scene

    numpy_engine = engines.ENGINES["numpy"]
    calls = {}

    def counted(name, function):
        def run(*args, **kwargs):
            calls[name] = calls.get(name, 0) + 1
            return function(*args, **kwargs)
        return run

    class CountedFFT:
        def __getattr__(self, name):
            return counted(f"fft.{name}", getattr(numpy_engine.fft, name))

    terms = numpy_engine.scene_terms["segmented_chip"]
    copy = dataclasses.replace(
        numpy_engine, name="x",
        **{op: counted(op, getattr(numpy_engine, op)) for op in
           ("pixel_mean", "accumulate", "accumulate_merged", "accumulate_bands")},
        fft=CountedFFT(), scene_terms={"segmented_chip": counted("chip", terms)})
    monkeypatch.setitem(engines.ENGINES, "x", copy)

    def compiled(*args, **kwargs):
        raise AssertionError("compiled code ran")

    for module, name in ((launch, "accumulate_kernel"), (bands, "band_kernel"),
                         (chip_scene, "evaluate_compiled")):
        monkeypatch.setattr(module, name, compiled)
    camera = rs.Camera.preset("nist-ir-psf").replace(assumed_emissivity=0.8)
    stack = rs.FrameStack(np.random.default_rng(3).uniform(400.0, 1100.0, (6, 40, 50)),
                          dt=1e-6, dx=1e-6, emissivity=0.8)
    stack.set_environment(reflected_temperature=300.0)
    chip = SegmentedChip(dx=6e-6, dt=1e-6)
    for scene, window in ((stack, 4e-6), (chip, 3e-6)):
        results = {}
        for name in ("numpy", "x"):
            engines.set_engine(name)
            try:
                results[name] = camera.measure(scene, window, rng=5)
            finally:
                engines.set_engine(None)
        for field in ("apparent_temperature", "signal_mean", "tensor_mean", "tensor_std",
                      "counts"):
            np.testing.assert_array_equal(getattr(results["x"], field),
                                          getattr(results["numpy"], field), field)
    assert {"accumulate_merged", "accumulate_bands", "fft.rfft", "fft.irfft", "chip"} <= set(calls)


def test_an_engine_given_as_an_argument_reaches_the_scenes_own_terms(monkeypatch):
    # An engine passed to the integrator (not registered, not set for the process) also makes
    # the built-in chip's frames: an engine made from numpy runs no compiled chip kernel and
    # gives the numpy engine's bits, and one without the chip's terms takes their numpy
    # reference.
    import dataclasses

    from radiosim.integrator import FootprintIntegrator, Window, integrate
    from radiosim.kernels import engines
    from radiosim.response import LinearResponse
    from radiosim.scenes import SegmentedChip
    from radiosim.scenes.segmented_chip import scene as chip_scene

    chip = SegmentedChip(dx=8e-6, dt=1e-6)
    integrator = FootprintIntegrator.for_scene(chip, 16e-6, 1.0, None)
    window = Window(chip.event_time - 1.5e-6, 3e-6)
    expected = integrate(chip, integrator, window, LinearResponse(), engine="numpy")

    def compiled(*args, **kwargs):
        raise AssertionError("the compiled chip kernel ran")

    monkeypatch.setattr(chip_scene, "evaluate_compiled", compiled)
    numpy_engine = engines.ENGINES["numpy"]
    for engine in (dataclasses.replace(numpy_engine, name="y"),
                   dataclasses.replace(numpy_engine, name="z", scene_terms={})):
        got = integrate(chip, integrator, window, LinearResponse(), engine=engine)
        for field in ("mean", "std", "max", "signal_mean"):
            np.testing.assert_array_equal(getattr(got, field), getattr(expected, field))

"""The segmented-chip scene's compiled moving terms against their numpy reference.

The kernel (``segmented_chip.kernel.moving_terms_kernel``) and the reference
(``segmented_chip.reference.evaluate_reference``) must agree to 1e-12 relative in temperature
and exactly in the region map: at full and coarse resolution, across a period (forming band
absent, during the slip, growing, at the event time), for whole frames, ``region`` arguments
and crops.
"""

import subprocess
import sys

import numba
import numpy as np
import pytest

from radiosim.kernels import get_engine, set_engine
from radiosim.scenes import ChipParameters, SegmentedChip
from radiosim.scenes import segmented_chip as sc
from radiosim.scenes.segmented_chip import kernel as chip_kernel

RTOL = 1e-12


@pytest.fixture(autouse=True)
def _engine_setting_restored():
    # Tests select the numpy or the compiled engine; every test starts and ends on the default.
    set_engine(None)
    yield
    set_engine(None)


@pytest.fixture(scope="module")
def scenes():
    """Full resolution (the default grid) and two coarse ones."""
    return {dx: SegmentedChip(dx=dx) if dx else SegmentedChip() for dx in (None, 2e-6, 4e-6)}


def times(scene):
    """Times across one period, relative to the start of the period after the event."""
    p = scene.params
    start = scene.event_time + 0.5 * scene.dt  # a period starts here (band release)
    return {
        "event": scene.event_time,  # the fully developed band, just before its release
        "release": start,  # τ = 0: d = 0, base = 0
        "slip": start + 0.4 * p.slip_time,  # the chip slips, no forming band (base = 0)
        "slip end": start + p.slip_time,  # base = 0 exactly
        "band starts": start + 1.05 * p.slip_time,  # base small: a narrow reach
        "mid cycle": start + 0.47 * p.period,
        "late": start + 0.93 * p.period,
        "t = 0": 0.0,
        "far": 1234.5 * p.period + 17e-6,
    }


def assert_agree(scene, t, region=None):
    region = region or scene._full()
    t_ref, r_ref = scene._evaluate(t, region, want_regions=True, engine="numpy")
    t_new, r_new = scene._evaluate(t, region, want_regions=True, engine="compiled")
    assert t_new.shape == t_ref.shape and t_new.dtype == np.float64
    np.testing.assert_allclose(t_new, t_ref, rtol=RTOL, atol=0)
    np.testing.assert_array_equal(r_new, r_ref)
    assert r_new.dtype == r_ref.dtype
    # Without the region map, the same temperatures.
    np.testing.assert_array_equal(scene._evaluate(t, region, engine="compiled"), t_new)
    return t_ref, r_ref


def test_the_times_cover_the_phases_of_the_forming_band(scenes):
    scene = scenes[4e-6]
    base = {name: scene._forming_base(scene._phase(t)[1]) for name, t in times(scene).items()}
    assert base["release"] == base["slip"] == base["t = 0"] == 0.0
    assert base["slip end"] < 1e-9
    assert 0 < base["band starts"] < 0.1 < base["mid cycle"] < base["late"] < base["event"] <= 1
    assert scene._phase(times(scene)["release"])[0] < 1e-9  # τ = 0, not τ = P


@pytest.mark.parametrize("dx", [None, 2e-6, 4e-6], ids=["full", "2um", "4um"])
def test_full_frames_agree_across_a_period(scenes, dx):
    scene = scenes[dx]
    for name, t in times(scene).items():
        temperature, regions = assert_agree(scene, t)
        assert (regions == sc.REGIONS["air"]).any(), name


@pytest.mark.parametrize("dx", [None, 2e-6, 4e-6], ids=["full", "2um", "4um"])
def test_regions_agree_across_a_period(scenes, dx):
    scene = scenes[dx]
    rows, cols = scene.shape
    regions = [
        (slice(rows // 9, rows // 2), slice(cols // 5, cols - cols // 7)),  # chip, L0, tool
        (slice(0, rows // 3), slice(cols // 3, cols)),  # the free surface
        (slice(rows // 3, rows), slice(0, cols)),  # the tool tip and below
        (slice(rows - 20, rows), slice(0, 30)),  # workpiece only: no chip, no band
        (slice(5, 6), slice(0, cols)),  # one row
        (slice(0, rows), slice(cols // 2, cols // 2 + 1)),  # one column
    ]
    full = {t: scene._evaluate(t, scene._full(), want_regions=True, engine="compiled")
            for t in list(times(scene).values())[:7]}
    for region in regions:  # regions outer: each region's static data is built once
        for t, (full_t, full_r) in full.items():
            temperature, region_map = assert_agree(scene, t, region)
            # A region is a slice of the full frame (to rounding: its ζ profile grid differs).
            np.testing.assert_allclose(temperature, full_t[region], rtol=RTOL, atol=0)
            np.testing.assert_array_equal(region_map, full_r[region])


def test_other_parameters_and_an_odd_pitch_agree():
    params = ChipParameters().replace(
        band_exponent_tip=0.5, band_exponent_reach=0.3, rake_fade=5e-6, released_bands=3,
        modulation=0.4, segmentation_degree=0.4, slip_fraction=0.3, band_initial_width=30e-6,
        tool_tip_x=650e-6, ambient_temperature=300.0)
    scene = SegmentedChip(params, dx=3.3e-6, dt=0.7e-6)
    for t in times(scene).values():
        assert_agree(scene, t)
        assert_agree(scene, t, (slice(13, 170), slice(41, 250)))


def test_crops_agree(scenes, monkeypatch):
    scene = scenes[2e-6]
    crop = scene.crop((40, 250), (100, 390))
    ks = [int(round(t / scene.dt)) for t in times(scene).values()]
    set_engine("numpy")
    reference = [crop.frame(k) for k in ks]
    reference_sample = crop.sample(ks[0])
    set_engine("compiled")
    for k, expected in zip(ks, reference):
        np.testing.assert_allclose(crop.frame(k), expected, rtol=RTOL, atol=0)
    np.testing.assert_allclose(crop.sample(ks[0]).temperature, reference_sample.temperature,
                               rtol=RTOL, atol=0)


def test_per_region_emissivity_frames_carry_the_same_region_map(monkeypatch):
    scene = SegmentedChip(dx=4e-6, dt=1e-6, emissivity={"chip": 0.3, "tool": 0.5})
    k = int(scene.event_time / scene.dt) - 20
    set_engine("numpy")
    reference = scene.sample(k)
    set_engine("compiled")
    compiled = scene.sample(k)
    np.testing.assert_array_equal(compiled.regions, reference.regions)
    np.testing.assert_allclose(compiled.temperature, reference.temperature, rtol=RTOL, atol=0)


def test_the_compiled_kernel_is_the_default(scenes, monkeypatch):
    scene = scenes[4e-6]
    t = scene.event_time - 33e-6
    assert get_engine().name == "compiled"
    compiled = scene._evaluate(t, scene._full(), engine="compiled")
    reference = scene._evaluate(t, scene._full(), engine="numpy")
    np.testing.assert_array_equal(scene.temperature(t), compiled)
    set_engine("numpy")
    np.testing.assert_array_equal(scene.temperature(t), reference)
    np.testing.assert_array_equal(scene.regions(t),
                                  scene._evaluate(t, scene._full(), True, engine="numpy")[1])


def test_the_kernel_recomputes_the_geometry_bitwise(scenes):
    scene = scenes[2e-6]
    g = scene.geometry
    r = scene._prepared(scene._full())
    scene._evaluate(0.0, scene._full(), engine="compiled")
    n, zeta = chip_kernel.kernel_coordinates(r.x, r.y, r.kernel.constants)
    np.testing.assert_array_equal(n, g.n)
    np.testing.assert_array_equal(zeta, g.zeta)


def test_results_do_not_depend_on_the_number_of_threads(scenes):
    scene = scenes[2e-6]
    t = scene.event_time - 12e-6
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = scene._evaluate(t, scene._full(), want_regions=True, engine="compiled")
    finally:
        numba.set_num_threads(threads)
    many = scene._evaluate(t, scene._full(), want_regions=True, engine="compiled")
    np.testing.assert_array_equal(one[0], many[0])
    np.testing.assert_array_equal(one[1], many[1])


def test_exp_matches_numpy():
    x = np.concatenate([np.linspace(-700, 700, 20001), -np.logspace(-12, 2.5, 2001),
                        np.logspace(-12, 2.5, 2001), [0.0, -0.0]])
    got = np.array([chip_kernel._exp(v) for v in x[::37]])
    np.testing.assert_allclose(got, np.exp(x[::37]), rtol=1e-15, atol=0)


def test_importing_compiles_nothing():
    code = ("from numba.core.dispatcher import Dispatcher; "
            "import radiosim.scenes.segmented_chip; "
            "import radiosim.scenes.segmented_chip.kernel as m; "
            "jitted = [f for f in vars(m).values() if isinstance(f, Dispatcher)]; "
            "print(len(jitted), sum(len(f.signatures) for f in jitted))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    count, signatures = map(int, out.stdout.split())
    assert count > 10 and signatures == 0

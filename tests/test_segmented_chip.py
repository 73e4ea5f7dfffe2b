"""The segmented-chip scene: geometry, terms, periodicity, regions, parameters."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from radiosim import Camera
from radiosim.errors import RadiosimError
from radiosim.scenes import ChipParameters, SegmentedChip
from radiosim.scenes.segmented_chip import (
    COLUMNS,
    REGIONS,
    hermite_step,
    jaeger_band_source,
    tanh_step,
)

COARSE = 2e-6  # a coarse grid keeps these tests fast


@pytest.fixture(scope="module")
def scene():
    return SegmentedChip(dx=COARSE, dt=0.5e-6)


def test_derived_quantities_match_the_specification():
    p = ChipParameters()
    assert math.degrees(p.shear_angle) == pytest.approx(27.1, abs=0.05)
    assert p.chip_thickness * 1e6 == pytest.approx(545.45, abs=0.01)
    assert p.chip_speed * 1e6 * 1e-6 == pytest.approx(2.2917, abs=1e-4)  # µm/µs
    assert p.segment_pitch * 1e6 == pytest.approx(206.25, abs=0.01)
    assert p.max_thickness * (1 - p.segmentation_degree) == pytest.approx(p.min_thickness)
    assert (p.max_thickness + p.min_thickness) / 2 == pytest.approx(p.chip_thickness, rel=0.01)


def test_default_grid_and_reference_locations():
    scene = SegmentedChip()
    assert scene.shape == (1113, 1440)
    assert scene.dx == pytest.approx(960e-6 / 1440)
    assert scene.column_x("I") * 1e6 == pytest.approx(227.0, abs=0.5)
    assert scene.column_x("I") < scene.column_x("II") < scene.column_x("III") < 700e-6
    # The event frame is the last one before a band release, at its mid-time.
    p = scene.params
    assert (scene.event_time + 0.5 * scene.dt) % p.period == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(RadiosimError, match="unknown column"):
        scene.column_x("IV")


def test_periodic_in_time(scene):
    t = 12.3e-6
    np.testing.assert_allclose(scene.temperature(t), scene.temperature(t + 3 * 90e-6),
                               rtol=0, atol=1e-9)


def test_regions_and_their_temperatures(scene):
    p = scene.params
    t = scene.event_time
    regions, temperature = scene.regions(t), scene.temperature(t)

    def at(x_um, y_um):
        i = int((p.field_height - y_um * 1e-6) / COARSE)
        j = int(x_um * 1e-6 / COARSE)
        return regions[i, j], temperature[i, j]

    assert at(800, 500)[0] == REGIONS["tool"]
    assert at(400, 100) == (REGIONS["workpiece"], pytest.approx(p.initial_temperature))
    assert at(500, 500)[0] == REGIONS["chip"]
    assert at(900, 200)[0] == REGIONS["workpiece"]  # below the machined surface
    assert at(50, 730) == (REGIONS["air"], pytest.approx(p.ambient_temperature))
    assert set(np.unique(regions)) == set(REGIONS.values())
    # The saw-tooth free surface moves: the chip/air boundary differs mid-cycle.
    assert not np.array_equal(regions, scene.regions(t - 45e-6))


def test_region_evaluation_equals_a_slice_of_the_full_frame(scene):
    t = scene.event_time - 20e-6
    full = scene.temperature(t)
    region = (slice(40, 200), slice(100, 330))
    np.testing.assert_allclose(scene.temperature(t, region), full[region], rtol=0, atol=1e-9)
    crop = scene.crop((40, 200), (100, 330))
    k = 1234
    np.testing.assert_allclose(crop.frame(k), scene.frame(k)[40:200, 100:330], rtol=0,
                               atol=1e-9)


def reference_chip_temperature(scene, t, i, j):
    """Plain, term-by-term evaluation of docs/scene.md at chip samples (no tables of the moving
    terms, no reach limits), for comparison with the fast evaluator."""
    p, g = scene.params, scene.geometry
    tau = t % p.period
    theta = tau / p.period
    d = p.chip_speed * ((1 - p.slip_fraction) * tau
                        + p.slip_fraction * p.period * hermite_step(tau / p.slip_time))
    s, n, zeta, xi = g.s[i, j], g.n[i, j], g.zeta[i, j], g.xi[i, j]
    sin_b = math.sin(p.band_angle)

    def tb(x):
        return p.initial_temperature + p.primary_rise * tanh_step(
            (x - p.primary_offset) / p.primary_width)

    # Secondary modulation: static field × (1 + a cos(2π(θ − θ_m) − 2π s / p_c))
    static = g.static[i, j]
    secondary = (static - tb(xi))
    total = tb(xi) + secondary * (1 + p.modulation * np.cos(
        2 * np.pi * (theta - p.modulation_phase) - 2 * np.pi * s / p.segment_pitch))
    fade = tanh_step(n / p.rake_fade)
    for k in range(p.released_bands):
        zk = d + k * p.segment_pitch
        sigma2 = p.band_width**2 + 2 * p.chip_diffusivity * (tau + k * p.period)
        total += (p.band_amplitude + tb(0.0) - tb(zk * sin_b)) * np.sqrt(
            p.band_width**2 / sigma2) * np.exp(-((zeta - zk) * sin_b) ** 2 / (2 * sigma2)) * fade
    base = np.clip((theta - p.slip_time / p.period) / (1 - p.slip_time / p.period), 0, 1)
    m = p.band_exponent_tip + (1 - p.band_exponent_tip) * np.clip(
        n / (p.band_exponent_reach * p.chip_thickness), 0, 1)
    f = base**m
    sigma = p.band_width + (p.band_initial_width - p.band_width) * (1 - f) ** 2
    total += p.band_amplitude * f * np.exp(-xi**2 / (2 * sigma**2)) * fade
    return total


@pytest.mark.parametrize("offset_us", [0.0, 2.0, 30.0, 61.7, 89.6])
def test_fast_evaluator_matches_the_term_by_term_reference(scene, offset_us):
    t = scene.event_time - offset_us * 1e-6
    temperature, regions = scene.temperature(t), scene.regions(t)
    i, j = np.nonzero(regions == REGIONS["chip"])
    pick = np.random.default_rng(1).choice(i.size, 4000, replace=False)
    i, j = i[pick], j[pick]
    expected = reference_chip_temperature(scene, t, i, j)
    # The released bands are interpolated linearly from a profile on a ≤ 0.05 µm grid:
    # error ≤ A/σ² · h²/8, far below 0.01 K.
    np.testing.assert_allclose(temperature[i, j], expected, rtol=0, atol=0.01)


def test_secondary_zone_table_matches_direct_quadrature():
    p = ChipParameters()
    s, n, shape = jaeger_band_source(p, 700e-6, 150e-6, 0.5e-6)
    full = p.full_flux_fraction * p.contact_length

    def q(x):
        return min(1.0, max(0.0, (p.contact_length - x) / (p.contact_length - full)))

    def direct(si, ni):
        c = ni**2 * p.chip_speed / (4 * p.secondary_diffusivity)
        # r = w²: ∫ q(s − r) r^{-1/2} e^{-c/r} dr = 2 ∫ q(s − w²) e^{-c/w²} dw
        value, _ = quad(lambda w: 2 * q(si - w * w) * math.exp(-c / (w * w)) if w > 0 else
                        (2 * q(si) if c == 0 else 0.0), 0, math.sqrt(si), limit=400,
                        points=[math.sqrt(max(si - full, 0)), math.sqrt(max(si - p.contact_length,
                                                                              0))])
        return value * (1 - p.tool_sink * math.exp(-ni / p.tool_sink_depth))

    points = [(200e-6, 10e-6), (400e-6, 3e-6), (600e-6, 40e-6), (100e-6, 0.0)]
    ref = [direct(si, ni) for si, ni in points]
    got = [shape[int(round(ni / 0.5e-6)), int(round(si / 0.5e-6))] for si, ni in points]
    # Compare shapes (the table is normalised): ratios to the first point, within the error of
    # a flux taken constant over 0.5 µm cells.
    np.testing.assert_allclose(np.array(got) / got[0], np.array(ref) / ref[0], rtol=2e-3)


def test_parameters_round_trip_through_toml(tmp_path):
    p = ChipParameters().replace(band_width=9e-6, released_bands=4)
    path = tmp_path / "chip.toml"
    p.to_toml(path)
    q = ChipParameters.from_toml(path)
    assert q == p or all(math.isclose(getattr(q, f), getattr(p, f), rel_tol=1e-12)
                         for f in p.__dataclass_fields__)
    assert "band_width_um = 9.0" in path.read_text()
    assert SegmentedChip(path, dx=8e-6).params.released_bands == 4


@pytest.mark.parametrize("text, message", [
    ("[chip]\nband_widht_um = 3\n",
     r"chip parameters: unknown key\(s\) band_widht_um \(did you mean band_width_um\?\)"),
    ("[chip]\nband_width_um = -3\n", "band_width must be > 0"),
    ("[chip]\nchip_ratio = 1.5\n", r"chip_ratio must be in \(0, 1\)"),
    ("[chip]\nrake_angle_deg = -5\n", "right-angle wedge"),
    ("[chip]\nperiod_us = 'long'\n", "must be a number"),
    ("[chip\n", "not valid TOML"),
])
def test_bad_parameters_are_named(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(RadiosimError, match=message):
        ChipParameters.from_toml(path)


def test_per_region_emissivity_reaches_the_camera():
    dx, dt = 2e-6, 1e-6
    camera = Camera.preset("nist-ir").replace(name="test")
    camera = camera.replace(electronics=camera.electronics.__class__(shot_noise=False,
                                                                     gain=1.0))
    blackbody = SegmentedChip(dx=dx, dt=dt)
    grey_chip = SegmentedChip(dx=dx, dt=dt, emissivity={"chip": 0.25})
    m1 = camera.measure(blackbody, 2e-6)
    m2 = camera.measure(grey_chip, 2e-6)
    # Region of every sample in every frame of the window (the free surface moves).
    frames = range(int(m1.t_start / dt), int(np.ceil(m1.t_stop / dt)))
    regions = np.stack([blackbody.regions((k + 0.5) * dt) for k in frames])
    step = 3  # 6 µm pixels of 2 µm samples
    pix = regions[:, : m1.shape[0] * step, : m1.shape[1] * step].reshape(
        len(frames), m1.shape[0], step, m1.shape[1], step)
    only_chip = (pix == REGIONS["chip"]).all(axis=(0, 2, 4))
    no_chip = (pix != REGIONS["chip"]).all(axis=(0, 2, 4))
    assert only_chip.sum() > 1000 and no_chip.sum() > 1000
    ratio = m2.signal_mean / m1.signal_mean
    np.testing.assert_allclose(ratio[only_chip], 0.25, rtol=1e-12)
    np.testing.assert_allclose(ratio[no_chip], 1.0, rtol=1e-12)
    with pytest.raises(RadiosimError, match="unknown region"):
        SegmentedChip(dx=dx, emissivity={"swarf": 0.2})


def test_columns_table_is_what_the_scene_uses():
    p = ChipParameters()
    for name, distance in COLUMNS.items():
        x = SegmentedChip(dx=8e-6).column_x(name)
        along = (p.tool_tip_x - x) / math.cos(p.shear_angle)
        assert along * math.cos(p.shear_angle + p.clearance_angle) == pytest.approx(distance)


def test_reflected_field_sees_the_interface_only_near_the_rake_face():
    scene = SegmentedChip(dx=4e-6)
    g, p = scene.geometry, scene.params
    ambient = p.ambient_temperature
    field = scene.reflected_field(view_length=5e-6)
    assert np.all(field[~g.chip_max] == ambient)
    assert field.max() <= g.face_temperature.max() + 1e-9
    # Within one sample of the face along the contact the weight exp(−n/ℓ) is ≥ e^{−0.8}.
    near = g.chip_max & (g.n < 4e-6) & (g.s > 0) & (g.s < p.contact_length)
    face = np.interp(g.s[near], g.face_s, g.face_temperature)
    excess = (field[near] - ambient) / (face - ambient)
    assert np.all(excess >= math.exp(-0.8) - 1e-12) and np.all(excess <= 1 + 1e-12)
    far = g.chip_max & (g.n > 60e-6)
    assert np.all(field[far] - ambient < (face.max() - ambient) * math.exp(-12))


def test_compiled_frames_are_checked_in_the_kernel(scene, monkeypatch):
    # The kernel checks each frame's values as it writes them: a clean frame is not read
    # again by the scene's check; anything else still is.
    import radiosim.scenes.base as base

    region = (slice(100, 180), slice(300, 420))
    expected = base.check_frame(scene.temperature(3.5 * scene.dt, region), 3, (100, 300))

    def unread(*args, **kwargs):
        raise AssertionError("the clean frame was read again")

    monkeypatch.setattr(base, "check_frame", unread)
    np.testing.assert_array_equal(scene.frame(3, region), expected)
    monkeypatch.undo()
    bad = expected.copy()
    bad[5, 7] = -1.0
    with pytest.raises(RadiosimError, match="frame 3: temperature at row 105, column 307 is -1 K"):
        scene._checked(bad, 3, region)


@pytest.mark.parametrize("value, what", [(np.nan, "is NaN"), (-3.0, "is -3 K"), (0.0, "is 0 K"),
                                         (-0.0, "is -0 K"), (np.inf, "is inf"),
                                         (-np.inf, "is -inf")])
def test_a_bad_value_the_kernel_writes_is_caught(value, what):
    # The kernel's count of values not finite and > 0 K flags NaN, ±0, negative and infinite
    # values alike.
    scene = SegmentedChip(dx=COARSE, dt=0.5e-6)
    region = (slice(0, 40), slice(0, 60))
    scene.frame(0, region)
    scene._prepared(region).static[5, 7] = value  # a field the frame starts from
    with pytest.raises(RadiosimError, match=f"frame 2: temperature at row 5, column 7 {what}"):
        scene.frame(2, region)


def test_only_the_kernels_own_frames_skip_the_check():
    # A subclass that changes the frames it reads, a frame of the numpy path or any other
    # array is still checked in full.
    from radiosim.kernels import set_engine

    region = (slice(0, 40), slice(0, 60))

    class Shifted(SegmentedChip):
        def _read(self, k, region):
            t = super()._read(k, region)
            t -= 2000.0  # in place, below 0 K
            return t

    with pytest.raises(RadiosimError, match="frame 2: temperature at row 0, column 0 is -"):
        Shifted(dx=COARSE, dt=0.5e-6).frame(2, region)
    scene = SegmentedChip(dx=COARSE, dt=0.5e-6)
    scene.temperature(1e-6, region)  # a clean frame, not read through frame()
    bad = np.full((40, 60), np.nan)
    with pytest.raises(RadiosimError, match="is NaN"):
        scene._checked(bad, 2, region)
    scene._prepared(region).static[5, 7] = np.nan
    for engine in ("compiled", "numpy"):
        set_engine(engine)
        try:
            with pytest.raises(RadiosimError, match="frame 2: temperature at row 5, column 7"):
                scene.frame(2, region)
        finally:
            set_engine(None)


@pytest.mark.usefixtures("in_tmp")
def test_region_emissivity_map_is_refused_naming_the_region():
    from radiosim.scenes import SegmentedChip

    scene = SegmentedChip(dx=8e-6, dt=1e-6)
    with pytest.raises(RadiosimError, match="emissivity of region 'chip' must be a number or"):
        SegmentedChip(dx=8e-6, dt=1e-6, emissivity={"chip": np.full(scene.shape, 0.3)})

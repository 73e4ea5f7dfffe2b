"""The Monte Carlo uncertainty budget (GUM Supplement 1) against closed forms, and its engine."""

import dataclasses
import math

import numpy as np
import pytest
from scipy.optimize import brentq

import radiosim as rs
from conftest import single_line
from radiosim import Camera
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.radiometry import band_radiance
from radiosim.scenes import UniformBlackbody
from radiosim.uncertainty import (HISTOGRAM_BINS, MAX_DRAWS, Normal, Samples, Triangular,
                                  TruncatedNormal, Uniform, distribution_from_table, propagate)


def ideal_planck(shape=(2, 2), assumed=0.3):
    base = rs.Camera.preset("nist-ir")
    return base.replace(electronics=rs.Electronics.ideal(), assumed_emissivity=assumed,
                        fpa=dataclasses.replace(base.fpa, shape=shape))


def test_one_uniform_emissivity_maps_its_quantiles_through_the_radiometry():
    """A uniform blackbody of true emissivity ε ~ U(0.2, 0.4) read by a camera set to
    ε_a = 0.3: T_app solves ε_a L(T_app) = ε L(T). T_app(ε) increases with ε, so its 2.5 % and
    97.5 % quantiles are T_app at ε's own quantiles, by direct quadrature and root finding.
    Tolerance: the standard error of a p-quantile of N draws, √(p(1−p)/N)·dT/dp (dT/dp =
    0.2·dT_app/dε ≈ 94 K), four times, plus the histogram's bin (16σ/400)."""
    camera = ideal_planck()
    scene = UniformBlackbody(900.0, shape=(12, 12), dx=6e-6, dt=1e-6, emissivity=0.3)
    n = 1000
    result = propagate(camera, scene, 10e-6, {"emissivity": Uniform(0.2, 0.4)}, draws=n,
                       rng=11, budget_draws=20)
    band, resp = camera.optics.band, camera.responsivity
    target = band_radiance(900.0, band, responsivity=resp)

    def apparent(emissivity):
        return brentq(lambda t: 0.3 * band_radiance(t, band, responsivity=resp)
                      - emissivity * target, 300.0, 2000.0, xtol=1e-9)

    low, high = result.interval(0.95)
    slope = (apparent(0.4) - apparent(0.2)) / 0.2  # [K per unit ε], about 470 K
    for p, got in ((0.025, low), (0.975, high)):
        expected = apparent(0.2 + 0.2 * p)
        tolerance = 4 * math.sqrt(p * (1 - p) / n) * 0.2 * slope + 16 * float(
            result.std[0, 0]) / HISTOGRAM_BINS
        np.testing.assert_allclose(got, expected, atol=tolerance)
    # The mean and standard deviation of T_app(ε) by quadrature over ε's uniform density.
    grid = np.linspace(0.2, 0.4, 201)
    values = np.array([apparent(e) for e in grid])
    mean = np.trapezoid(values, grid) / 0.2
    std = math.sqrt(np.trapezoid((values - mean) ** 2, grid) / 0.2)
    np.testing.assert_allclose(result.mean, mean, atol=4 * std / math.sqrt(n))
    np.testing.assert_allclose(result.std, std, rtol=4 / math.sqrt(2 * (n - 1)))
    # Scene truth: the blackbody's own temperature; the error is the mean reading's.
    np.testing.assert_allclose(result.truth, 900.0)
    np.testing.assert_allclose(result.error, result.mean - 900.0)


def gradient_scene():
    x = (np.arange(120) + 0.5) * 1e-6
    frames = np.broadcast_to(500.0 + 2e6 * x, (3, 30, 120)).copy()  # 2 K/µm along x
    return rs.FrameStack(frames, dt=1e-6, dx=1e-6)


def test_gum_and_monte_carlo_agree_for_a_linear_model():
    """The linear camera on a field rising 2 K/µm along x, its array registered with
    σ = 1 µm: each reading moves by exactly 2 K per µm (a footprint mean of a linear field),
    so GUM's u = 2 K, and the Monte Carlo standard deviation of N draws agrees within four
    of its standard errors, u·√(1/(2(N−1)))."""
    camera = rs.Camera.linear_ideal(6e-6, shape=(3, 15))
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, origin=(0.0, 10e-6)))
    n = 400
    result = propagate(camera, gradient_scene(), 2e-6, {"registration_x": Normal(0.0, 1e-6)},
                       draws=n, rng=3, t_start=0.0, budget_draws=200)
    np.testing.assert_allclose(result.gum_std, 2.0, rtol=1e-9)
    np.testing.assert_allclose(result.std, 2.0, rtol=4 / math.sqrt(2 * (n - 1)))
    gum_low, gum_high = result.gum_interval()
    low, high = result.interval()
    half = 1.959964 * 2.0
    np.testing.assert_allclose(high - low, 2 * half, rtol=0.1)  # Normal input, linear model
    np.testing.assert_allclose(gum_high - gum_low, 2 * half, rtol=4 / math.sqrt(2 * (n - 1)))
    peak = [r for r in result.budget if r["quantity"] == "peak"]
    assert [r["input"] for r in peak] == ["registration_x", "temporal noise"]
    assert peak[0]["sensitivity"] == pytest.approx(2e6, rel=1e-9)  # [K/m]
    assert peak[0]["mc_contribution_K"] == pytest.approx(2.0, rel=4 / math.sqrt(2 * 199))
    assert peak[1]["gum_contribution_K"] == 0.0  # the linear ideal camera has no noise


def test_the_same_draws_on_two_workers_give_the_same_bits():
    """Each draw's seed comes from one SeedSequence, and draws are accumulated in index
    order: a two-worker distributed LocalCluster reproduces the synchronous result exactly."""
    camera = ideal_planck().replace(electronics=rs.Camera.preset("nist-ir").electronics)
    scene = UniformBlackbody(800.0, shape=(12, 12), dx=6e-6, dt=1e-6, emissivity=0.3)
    inputs = {"emissivity": Uniform(0.25, 0.35), "t_start": Normal(0.0, 0.2e-6)}
    kwargs = dict(draws=12, rng=5, t_start=2e-6, batch=5, budget_draws=4)
    local = propagate(camera, scene, 5e-6, inputs, scheduler="synchronous", **kwargs)
    cluster = propagate(camera, scene, 5e-6, inputs, workers=2, **kwargs)
    for name in ("mean", "std", "gum_std", "valid_fraction"):
        assert np.array_equal(getattr(local, name), getattr(cluster, name), equal_nan=True)
    assert np.array_equal(np.array(local.interval()), np.array(cluster.interval()),
                          equal_nan=True)
    assert local.budget == cluster.budget
    assert local.std.max() > 0  # the inputs and the noise did vary


def test_the_adaptive_procedure_stops_within_its_draws():
    camera = rs.Camera.linear_ideal(6e-6, shape=(3, 15))
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, origin=(0.0, 10e-6)))
    result = propagate(camera, gradient_scene(), 2e-6, {"registration_x": Normal(0.0, 1e-6)},
                       rng=3, t_start=0.0, batch=40, max_draws=2000, digits=1, budget_draws=5)
    assert 80 <= result.draws < 2000
    np.testing.assert_allclose(result.std, 2.0, rtol=0.25)


def test_distributions_have_their_moments_and_tables():
    rng = np.random.default_rng(0)
    for dist, mean, std in ((Normal(1.0, 2.0), 1.0, 2.0), (Uniform(0.0, 1.0), 0.5, 12**-0.5),
                            (Triangular(0.0, 0.0, 3.0), 1.0, math.sqrt(0.5)),
                            (Samples([1.0, 3.0]), 2.0, 1.0)):
        draws = np.array([dist.sample(rng) for _ in range(20000)])
        assert dist.mean == pytest.approx(mean) and dist.std == pytest.approx(std)
        assert draws.mean() == pytest.approx(mean, abs=5 * std / math.sqrt(20000))
    truncated = TruncatedNormal(0.0, 1.0, 0.0, 5.0)  # mean (φ(0) − φ(5)) / (Φ(5) − Φ(0))
    phi = [math.exp(-z * z / 2) / math.sqrt(2 * math.pi) for z in (0.0, 5.0)]
    mass = 0.5 * math.erf(5 / math.sqrt(2))
    assert truncated.mean == pytest.approx((phi[0] - phi[1]) / mass, rel=1e-9)
    assert distribution_from_table({"distribution": "uniform", "low": 1.0, "high": 3.0},
                                   "psf_sigma") == Uniform(1e-6, 3e-6)  # µm in the file


@pytest.mark.parametrize("inputs, draws, message", [
    ({"emisivity": Uniform(0.2, 0.4)}, 10, "did you mean 'emissivity'"),
    ({"emissivity": (0.2, 0.4)}, 10, "must be a Distribution"),
    ({"emissivity": Uniform(0.2, 0.4)}, 1, "draws must be"),
])
def test_bad_budgets_are_named(inputs, draws, message):
    with pytest.raises(RadiosimError, match=message):
        propagate(ideal_planck(), UniformBlackbody(800.0, shape=(12, 12), dx=6e-6), 1e-6,
                  inputs, draws=draws)


@pytest.mark.parametrize("table, message", [
    ({"distribution": "cauchy"}, "distribution = one of"),
    ({"distribution": "uniform", "low": 1.0}, "needs low, high"),
    ({"distribution": "uniform", "low": 2.0, "high": 1.0}, "low < high"),
])
def test_bad_distribution_tables_are_named(table, message):
    with pytest.raises(RadiosimError, match=message):
        distribution_from_table(table, "emissivity")


def test_a_study_on_two_workers_equals_the_same_study_run_synchronously(tmp_path):
    """Every measurement a task with its own spawned seed: the same bits on any scheduler."""
    from conftest import frames_study

    from radiosim.study import Study

    rng = np.random.default_rng(0)
    np.save(tmp_path / "frames.npy", 600.0 + 50.0 * rng.random((6, 24, 24)))
    text = frames_study([1, 2, 3], 4.0)
    text += '\n[cameras.real]\nfile = "cam.toml"\n[[sweeps]]\nname = "r"\ncameras = ["real"]\n' \
            'integration_time_us = [1, 2]\n'
    camera = rs.Camera.preset("nist-ir")
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, pixel_pitch=4e-6, shape=None,
                                                    detector_pitch=20e-6))
    (tmp_path / "cam.toml").write_text(camera.to_toml())
    (tmp_path / "s.toml").write_text(text)
    study = Study.from_toml(tmp_path / "s.toml")
    local = study.run(None, rng=7, scheduler="synchronous").rows
    cluster = study.run(None, rng=7, workers=2, cluster="always").rows
    assert len(local) == 5
    assert local == cluster
    assert {r["sweep"] for r in local} == {"t", "r"}


def test_the_uncertainty_command_writes_its_budget(tmp_path, capsys, monkeypatch):
    import OpenEXR

    from radiosim import reporting
    from radiosim.cli import main
    from radiosim.io.exr import UNCERTAINTY_CHANNELS

    maps = []  # the map's y axis: y up from the bottom, as the scene's (and its figures')
    save = reporting.save_figure
    monkeypatch.setattr(reporting, "save_figure",
                        lambda fig, path: maps.append(fig.axes[0].get_ylim()) or save(fig, path))

    (tmp_path / "u.toml").write_text("""name = "u"
[scene]
type = "segmented-chip"
dx_um = 8.0
dt_us = 1.0
emissivity = 0.3
[cameras.nist]
preset = "nist-ir"
assumed_emissivity = 0.3
[uncertainty]
camera = "nist"
integration_time_us = 5
draws = 6
batch = 3
[uncertainty.inputs]
emissivity = {distribution = "uniform", low = 0.25, high = 0.35}
psf_sigma = {distribution = "uniform", low = 0.0, high = 4.0}
""")
    out = tmp_path / "out"
    assert main(["uncertainty", str(tmp_path / "u.toml"), "--out", str(out), "-q"]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ["budget.csv", "budget.png", "radiosim-manifest.json", "uncertainty.exr"]
    assert len(maps) == 1 and maps[0][0] == 0 < maps[0][1], maps  # bottom 0, top the height
    lines = (out / "budget.csv").read_text().splitlines()
    assert lines[0].startswith("quantity,input,distribution")
    assert len(lines) == 1 + 2 * 3  # peak and mean × (two inputs and the noise)
    with OpenEXR.File(str(out / "uncertainty.exr")) as exr:
        assert set(exr.channels()) == set(UNCERTAINTY_CHANNELS)
    capsys.readouterr()
    assert main(["uncertainty", str(tmp_path / "u.toml"), "--out", str(out)]) == 2
    assert "is not empty" in capsys.readouterr().err
    (tmp_path / "plain.toml").write_text((tmp_path / "u.toml").read_text().split(
        "[uncertainty]")[0] + '[[sweeps]]\nname = "t"\ncameras = ["nist"]\n'
        'integration_time_us = [1]\n')
    assert main(["uncertainty", str(tmp_path / "plain.toml"), "--out", str(tmp_path / "o2")]) == 2
    assert "no [uncertainty] table" in capsys.readouterr().err


def test_inputs_that_could_draw_invalid_values_are_refused_before_any_draw():
    """A normal assumed emissivity of 0.95 ± 0.03 exceeds 1 in 5 % of draws: refused up front,
    naming the input; the caller's SeedSequence is not spent."""
    scene = UniformBlackbody(800.0, shape=(12, 12), dx=6e-6, dt=1e-6, emissivity=0.3)
    with pytest.raises(RadiosimError, match="input 'assumed_emissivity'.*bounded"):
        propagate(ideal_planck(), scene, 1e-6, {"assumed_emissivity": Normal(0.95, 0.03)},
                  draws=4)
    with pytest.raises(RadiosimError, match="seed"):
        propagate(ideal_planck(), scene, 1e-6, {"emissivity": Uniform(0.2, 0.4)}, draws=4,
                  rng=np.random.default_rng(0))
    sequence = np.random.SeedSequence(9)
    first = propagate(ideal_planck(), scene, 1e-6, {"emissivity": Uniform(0.2, 0.4)},
                      draws=4, rng=sequence, budget_draws=2)
    again = propagate(ideal_planck(), scene, 1e-6, {"emissivity": Uniform(0.2, 0.4)},
                      draws=4, rng=sequence, budget_draws=2)
    assert np.array_equal(first.mean, again.mean)


def test_each_input_states_its_domain_as_a_record():
    import types

    from radiosim.uncertainty import INPUTS, Domain

    model = types.SimpleNamespace(t_start=2e-6, integration_time=5e-6,
                                  camera=types.SimpleNamespace(fpa=types.SimpleNamespace(
                                      origin=(3e-6, 4e-6))))
    domains = {name: record.domain(model) for name, record in INPUTS.items()}
    assert all(isinstance(d, Domain) for d in domains.values())
    assert domains["emissivity"] == Domain(0.0, 1.0, False)
    assert domains["assumed_emissivity"].open_low
    assert domains["t_start"] == Domain(-2e-6, float("inf"), False)
    assert domains["integration_time"] == Domain(-5e-6, float("inf"), True)
    assert domains["registration_x"].low == -4e-6 and domains["registration_y"].low == -3e-6


def moving_scene(n_frames=40):
    """A hot band sweeping along x at 1 µm per frame over a 600 K plate: 16 × 24 samples."""
    x = np.arange(24)[None, None, :]
    k = np.arange(n_frames)[:, None, None]
    frames = 600.0 + 400.0 * np.exp(-0.5 * ((x - 2.0 - 0.5 * k) / 2.0) ** 2)
    return rs.FrameStack(np.broadcast_to(frames, (n_frames, 16, 24)).copy(), dt=1e-6, dx=1e-6,
                         emissivity=0.3)


CHIP_LIKE = {"emissivity": Uniform(0.25, 0.35), "psf_sigma": Uniform(0.0, 2e-6),
             "t_start": Uniform(-3e-6, 3e-6), "calibration_scale": Normal(1.0, 0.01)}


def test_a_draw_from_running_sums_is_the_measurement_to_rounding():
    """A draw formed from the running sums (radiosim.budget_reuse: ε·Σ w_k L_k from prefix sums,
    blurred once) against Camera.measure of the same perturbed camera and scene (ε·L summed
    frame by frame): the same arithmetic up to the order of the sums, so the readings agree to
    1e-12 relative (rounding; measured 2e-14) — noise-free electronics, so that no ADC step
    amplifies a rounding."""
    import dataclasses as dc

    from radiosim import budget_reuse
    from radiosim.uncertainty import _Model

    camera, scene = ideal_planck(), moving_scene()
    model = _Model(camera, scene, 5.5e-6, 10.3e-6, CHIP_LIKE)
    plan = budget_reuse.ReusePlan.for_budget(camera, scene, *model.span())
    assert (plan.origin, plan.stop) == (7, 19)  # 7.3 µs … 18.8 µs: frames 7 to 18
    reused = dc.replace(model, plan=plan)
    try:
        for values in ({"emissivity": 0.3, "psf_sigma": 0.0, "t_start": 0.0,
                        "calibration_scale": 1.0},
                       {"emissivity": 0.27, "psf_sigma": 1.5e-6, "t_start": -2.9e-6,
                        "calibration_scale": 1.01},
                       {"emissivity": 0.34, "psf_sigma": 0.4e-6, "t_start": 2.45e-6,
                        "calibration_scale": 0.99}):
            got, expected = reused.evaluate(values, 1), model.evaluate(values, 1)
            assert np.all(np.isfinite(expected))
            np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)
        assert len(budget_reuse._KEPT) == 1  # one set of sums, whatever the draws
        assert budget_reuse._KEPT[plan.token].nbytes == 16 * 24 * 1 * (19 - 7 + 1) * 8
    finally:
        budget_reuse.release()


def test_running_sums_give_each_window_its_weighted_mean():
    """FrameSums.window_mean against the weighted sum of the frames' own signals, L(T_k) by
    the response itself, with the fractional first and last weights of the integrator."""
    from radiosim import budget_reuse
    from radiosim.integrator import Window

    camera, scene = ideal_planck(), moving_scene(12)
    plan = budget_reuse.ReusePlan.for_budget(camera, scene, 1e-6, 11e-6)
    sums = budget_reuse.FrameSums(plan)
    response, black = camera.response_model, scene.with_emissivity(1.0)
    for start, duration, weights in ((1.25e-6, 3.5e-6, [0.75, 1, 1, 0.75]),
                                     (3e-6, 1e-6, [1]), (2.5e-6, 1.0e-6, [0.5, 0.5])):
        first = int(start // 1e-6)
        expected = sum(w / duration * 1e-6 * response.signal(black.sample(first + i))
                       for i, w in enumerate(weights))
        np.testing.assert_allclose(sums.window_mean(Window(start, duration))[0], expected,
                                   rtol=1e-13)


def test_budgets_give_the_same_bits_with_and_without_reuse_and_on_two_workers():
    """The chip budget's inputs (emissivity, PSF σ, window start, calibration scale) and the
    noise: draws from running sums kept between draws, draws that each make their own sums (one
    pass over the frames), and the kept sums on a two-worker cluster give the same bits."""
    camera = ideal_planck().replace(electronics=rs.Camera.preset("nist-ir").electronics)
    kwargs = dict(draws=6, rng=23, t_start=10.3e-6, batch=3, budget_draws=2)
    reused = propagate(camera, moving_scene(), 5.5e-6, CHIP_LIKE, scheduler="synchronous",
                       **kwargs)
    straight = propagate(camera, moving_scene(), 5.5e-6, CHIP_LIKE, scheduler="synchronous",
                         reuse=False, **kwargs)
    cluster = propagate(camera, moving_scene(), 5.5e-6, CHIP_LIKE, workers=2, **kwargs)
    for other in (straight, cluster):
        for name in ("mean", "std", "gum_std", "valid_fraction"):
            assert np.array_equal(getattr(reused, name), getattr(other, name), equal_nan=True)
        assert np.array_equal(np.array(reused.interval()), np.array(other.interval()),
                              equal_nan=True)
        assert reused.budget == other.budget
    assert reused.std.min() > 0


def test_the_budget_table_states_u_in_the_study_files_units():
    # u(x) as the study file states the input (µm, µs, K, none), the temporal noise without
    # one (it has no u(x) of its own): not SI values without a unit, not 'nan'.
    from types import SimpleNamespace

    from radiosim.reporting import budget_lines

    rows = [dict(quantity="peak", input=name, std_uncertainty=u, gum_contribution_K=g,
                 mc_contribution_K=g, share_percent=s)
            for name, u, g, s in (("psf_sigma", 1.5e-6, 3.0, 30.0),
                                  ("t_start", 2.0e-7, 2.0, 20.0),
                                  ("emissivity", 0.05, 4.0, 45.0),
                                  ("temporal noise", float("nan"), 1.0, 5.0))]
    field = np.full((2, 2), 900.0)
    result = SimpleNamespace(budget=rows, mean=field, std=field * 0 + 3.0, truth=field,
                             interval=lambda p: (field - 6.0, field + 6.0))
    lines = {line.split()[0]: line for line in budget_lines(result)[1:-1]}
    assert "1.5 µm" in lines["psf_sigma"] and "0.2 µs" in lines["t_start"]
    assert lines["emissivity"].split()[1] == "0.05"
    assert "—" in lines["temporal"] and "nan" not in " ".join(lines.values())


def test_a_draw_that_moves_the_array_off_the_scene_is_named():
    """18 pixels of 6 µm from x = 10 µm end at 118 µm of a 120 µm scene: a registration draw
    of more than 2 µm leaves a column without scene, so that draw would see 17 columns. One
    line naming the draw, not a broadcasting error (nor a silently smaller image)."""
    camera = rs.Camera.linear_ideal(6e-6, shape=(3, 18))
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, origin=(0.0, 10e-6)))
    message = (r"a draw \(registration_x = .*\) sees 3 × 17 pixels of the scene, the nominal "
               r"camera 3 × 18")
    with pytest.raises(RadiosimError, match=message) as info:
        propagate(camera, gradient_scene(), 2e-6, {"registration_x": Uniform(0.0, 4e-6)},
                  draws=40, rng=3, t_start=0.0, budget_draws=20)
    assert "\n" not in str(info.value)


# -- the engine's bounds: draws, domains, progress, warnings ---------------------------------------


def small_budget_case(tmp_path):
    from radiosim.scenes import FrameStack

    scene = FrameStack(np.full((4, 12, 12), 700.0), dt=1e-6, dx=1e-6)
    return Camera.linear_ideal(3e-6), scene


def test_a_huge_draw_count_is_refused_naming_the_bound(tmp_path):
    camera, scene = small_budget_case(tmp_path)
    with pytest.raises(RadiosimError) as info:
        propagate(camera, scene, 2e-6, {"emissivity": Uniform(0.8, 0.9)}, draws=100_000_000)
    single_line(str(info.value), "draws", "100000000", str(MAX_DRAWS))


def test_progress_gives_a_time_estimate(tmp_path):
    camera, scene = small_budget_case(tmp_path)
    calls = []
    propagate(camera, scene, 2e-6, {"emissivity": Uniform(0.8, 0.9)}, draws=6, batch=2,
              rng=0, budget_draws=2, progress=lambda done, total, left: calls.append(
                  (done, total, left)))
    assert [c[:2] for c in calls] == [(2, 6), (4, 6), (6, 6)]
    assert all(left is not None and left >= 0 for _, _, left in calls)
    assert calls[-1][2] == 0


@pytest.mark.parametrize("name, dist, domain", [
    ("psf_sigma", Uniform(-5e-6, 1e-6), "[0, inf]"),
    ("emissivity", Uniform(0.5, 1.2), "[0, 1]"),
    ("halo_fraction", Normal(0.01, 0.02), "(0, 1]"),
])
def test_an_input_range_outside_its_domain_is_refused_naming_it(tmp_path, name, dist, domain):
    camera, scene = small_budget_case(tmp_path)
    with pytest.raises(RadiosimError) as info:
        propagate(camera, scene, 2e-6, {name: dist}, draws=2)
    single_line(str(info.value), repr(name), "domain", domain)


def test_a_negative_psf_sigma_is_named_in_micrometres(tmp_path):
    camera, scene = small_budget_case(tmp_path)
    with pytest.raises(RadiosimError) as info:
        propagate(camera, scene, 2e-6, {"psf_sigma": Uniform(-5e-6, 1e-6)}, draws=2)
    single_line(str(info.value), "-5", "µm")


def test_a_budgets_warnings_reach_the_caller(tmp_path):
    camera = Camera.preset("nist-ir").replace(response="linear").with_pixel_pitch(4e-6)
    from radiosim.scenes import FrameStack

    scene = FrameStack(np.full((4, 12, 12), 1000.0), dt=1e-6, dx=1e-6)
    with pytest.warns(RadiosimWarning, match="one DN"):
        result = propagate(camera, scene, 2e-6, {"emissivity": Uniform(0.8, 0.9)}, draws=4,
                           batch=2, rng=0, budget_draws=2)
    assert any("one DN" in text for text in result.warnings)

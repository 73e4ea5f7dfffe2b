"""
The thermography equation (reflection, path) and the optics' own emission, checked against the
in-band radiance arithmetic done here with our own Planck quadrature (scipy Simpson over the
camera's spectral curves, linearly interpolated) and scipy.optimize.brentq:

    S = τ (ε L(T) + (1 − ε) L(T_refl)) + (1 − τ) L(T_path) + E(T_instrument),
    E(T_i) = ∫ (1 − τ_optics(λ)) · filter(λ) · QE(λ) · L_q(λ, T_i) dλ,

with L the photon radiance through filter × optics × QE. The camera inverts S with its own
settings; with settings equal to the truth it must return the truth, and otherwise the bias the
arithmetic gives.
"""

import dataclasses
import math

import numpy as np
import pytest
from scipy import constants, integrate, optimize

import radiosim as rs
from radiosim.calibration import Calibration
from radiosim.electronics import Electronics
from radiosim.errors import RadiosimError
from radiosim.scenes import UniformBlackbody

C2 = constants.h * constants.c / constants.k  # [m K]


def camera_for(optics_changes=None, electronics=None, **settings):
    """nist-ir with 2 × 2 pixels (6 µm), ideal electronics unless given, and these settings."""
    camera = rs.Camera.preset("nist-ir")
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, shape=(2, 2)),
                            electronics=electronics or Electronics.ideal(), **settings)
    if optics_changes:
        camera = camera.replace(optics=dataclasses.replace(camera.optics, **optics_changes))
    return camera


def scene_for(temperature, emissivity=1.0, **environment):
    """A uniform 12 × 12 µm surface (2 × 2 pixels of 6 µm) in this environment; one 1 ms
    frame covers every window here."""
    scene = UniformBlackbody(temperature, shape=(12, 12), dx=1e-6, dt=1e-3,
                             emissivity=emissivity)
    return scene.set_environment(**environment)


class Radiometry:
    """In-band photon radiance of the camera's spectral curves, by our own quadrature:
    composite Simpson on a grid of 1/32 of the curves' 0.01 µm node spacing, the nodes on
    panel edges (the piecewise-linear curves are smooth within a panel), so the relative
    error is far below 1e-9."""

    def __init__(self, camera):
        lo, hi = camera.optics.band
        steps = round((hi - lo) / 1e-8) * 32
        self.wavelength = np.linspace(lo, hi, steps + 1)

        def curve(sd):
            if not hasattr(sd, "domain"):
                return np.full(self.wavelength.shape, float(sd))
            return np.interp(self.wavelength, np.asarray(sd.domain, dtype=float),
                             np.asarray(sd.values, dtype=float), left=0.0, right=0.0)

        self.filter = curve(camera.optics.spectral_filter)
        self.optics = curve(camera.optics.transmission)
        self.qe = curve(camera.fpa.quantum_efficiency)

    def planck(self, temperature):
        """Spectral photon radiance [photons s⁻¹ m⁻² sr⁻¹ m⁻¹]."""
        lam = self.wavelength
        return 2 * constants.c / lam**4 / np.expm1(C2 / (lam * temperature))

    def _integral(self, weight, temperature):
        return float(integrate.simpson(weight * self.planck(temperature), x=self.wavelength))

    def L(self, temperature):
        """The scene radiance the camera sees: through filter × optics × QE."""
        return self._integral(self.filter * self.optics * self.qe, temperature)

    def emission(self, temperature):
        """The optics' own emission into the pixel: (1 − τ) × filter × QE."""
        return self._integral((1 - self.optics) * self.filter * self.qe, temperature)

    def temperature(self, radiance):
        """The temperature whose L is ``radiance`` (brentq to 1e-10 K)."""
        return optimize.brentq(lambda t: self.L(t) - radiance, 100.0, 4000.0, xtol=1e-10)


def observed(rad, t, emissivity, reflected, tau, path, instrument):
    """S by the thermography equation and the optics' emission (None: that term is absent)."""
    reflection = 0.0 if reflected is None else (1 - emissivity) * rad.L(reflected)
    path_term = 0.0 if path is None else (1 - tau) * rad.L(path)
    emission = 0.0 if instrument is None else rad.emission(instrument)
    return tau * (emissivity * rad.L(t) + reflection) + path_term + emission


def apparent(rad, signal, emissivity, reflected, tau, path, instrument):
    """The temperature a camera with these settings assigns to S (its own arithmetic)."""
    reflection = 0.0 if reflected is None else (1 - emissivity) * rad.L(reflected)
    path_term = 0.0 if path is None else (1 - tau) * rad.L(path)
    emission = 0.0 if instrument is None else rad.emission(instrument)
    emitted = (signal - emission - path_term) / tau - reflection
    return rad.temperature(emitted / emissivity)


TRUTHS = {
    # T, ε, T_refl, τ_path, T_path, T_instrument
    "reflection only": (900.0, 0.65, 420.0, 1.0, None, None),
    "path only": (700.0, 1.0, None, 0.8, 310.0, None),
    "everything": (900.0, 0.4, 500.0, 0.85, 320.0, 300.0),
    "hot surround, cool body": (450.0, 0.3, 1100.0, 0.9, 295.0, 310.0),
}


def truth_camera_scene(case):
    t, eps, refl, tau, path, instr = TRUTHS[case]
    scene = scene_for(t, eps, reflected_temperature=refl, path_transmission=tau,
                      path_temperature=path)
    camera = camera_for({"instrument_temperature": instr}, assumed_emissivity=eps,
                        assumed_reflected_temperature=refl, assumed_path_transmission=tau,
                        assumed_path_temperature=path)
    return camera, scene


@pytest.mark.parametrize("case", list(TRUTHS))
def test_camera_with_true_settings_inverts_exactly(case):
    # The camera's calibration is the same forward model through the same tables, so with
    # its settings equal to the truth (and ideal electronics) it returns the truth to
    # rounding: 1e-6 K.
    camera, scene = truth_camera_scene(case)
    assert camera.forms_image(scene) == (TRUTHS[case][2] is not None or TRUTHS[case][3] < 1)
    m = camera.measure(scene, 1e-4)
    np.testing.assert_allclose(m.apparent_temperature, TRUTHS[case][0], atol=1e-6, rtol=0)


@pytest.mark.parametrize("case", list(TRUTHS))
def test_the_observed_signal_is_the_thermography_equation(case):
    # The image stage's mean signal (before the optics' emission, which read-out adds) and
    # the electrons, against our own quadrature: 1e-6 relative (the radiance tables' 1e-7).
    camera, scene = truth_camera_scene(case)
    t, eps, refl, tau, path, instr = TRUTHS[case]
    rad = Radiometry(camera)
    m = camera.measure(scene, 1e-4)
    expected = observed(rad, t, eps, refl, tau, path, None)
    np.testing.assert_allclose(m.signal_mean, expected, rtol=1e-6)
    total = observed(rad, t, eps, refl, tau, path, instr)
    np.testing.assert_allclose(m.electrons, total * camera.etendue * 1e-4, rtol=1e-6)


BIASED_SETTINGS = {
    "emissivity": dict(assumed_emissivity=0.5),
    "reflected temperature": dict(assumed_reflected_temperature=293.15),
    "path": dict(assumed_path_transmission=0.95, assumed_path_temperature=290.0),
    "instrument temperature": dict(assumed_instrument_temperature=250.0),
    "all": dict(assumed_emissivity=0.45, assumed_reflected_temperature=350.0,
                assumed_path_transmission=1.0, assumed_path_temperature=None,
                assumed_instrument_temperature=320.0),
}


@pytest.mark.parametrize("wrong", list(BIASED_SETTINGS))
def test_bias_of_wrong_settings_equals_the_radiance_arithmetic(wrong):
    # Truth: T = 900 K, ε = 0.4, T_refl = 500 K, τ = 0.85 at 320 K, optics at 300 K. The
    # camera's settings differ in one (or every) term; its reading must be the temperature
    # our arithmetic assigns to the same signal with the same settings. Tolerance: the
    # camera's radiance tables are good to 1e-7 relative, i.e. δT ≈ 1e-7 λT²/c2 ≈ 3e-5 K at
    # 900 K (≈ 1e-4 K after the subtractions of a low emissivity); 1e-3 K asserted.
    t, eps, refl, tau, path, instr = TRUTHS["everything"]
    settings = dict(assumed_emissivity=eps, assumed_reflected_temperature=refl,
                    assumed_path_transmission=tau, assumed_path_temperature=path,
                    assumed_instrument_temperature=instr)
    settings.update(BIASED_SETTINGS[wrong])
    camera = camera_for({"instrument_temperature": instr}, **settings)
    scene = scene_for(t, eps, reflected_temperature=refl, path_transmission=tau,
                      path_temperature=path)
    rad = Radiometry(camera)
    signal = observed(rad, t, eps, refl, tau, path, instr)
    expected = apparent(rad, signal, settings["assumed_emissivity"],
                        settings["assumed_reflected_temperature"],
                        settings["assumed_path_transmission"],
                        settings["assumed_path_temperature"],
                        settings["assumed_instrument_temperature"])
    assert abs(expected - t) > 5e-3  # a real bias, 5 × the tolerance
    m = camera.measure(scene, 1e-4)
    np.testing.assert_allclose(m.apparent_temperature, expected, atol=1e-3, rtol=0)


# -- 8. the optics' own emission -------------------------------------------------------------


def grey_lens_camera(instrument, assumed=None, electronics=None):
    """nist-ir with a grey lens (τ = 0.8) at ``instrument`` [K], calibrated at ``assumed``."""
    electronics = electronics or Electronics(shot_noise=False, gain=0.0014, offset=1000.0)
    return camera_for({"transmission": 0.8, "instrument_temperature": instrument},
                      electronics=electronics, assumed_instrument_temperature=assumed)


def test_optics_emission_adds_exactly_its_counts():
    # A grey lens of τ = 0.8 at T_i = 310 K emits (1 − τ) L_fq(T_i) (L_fq: photon radiance
    # through filter × QE) into the pixel's étendue G. With the working cone set by the
    # objective, G = A_image π sin²θ' = ff (p m)² π (NA/m)² = π ff p² NA². Counts rise by
    # (1 − τ) L_fq(T_i) G t K exactly: 1e-6 relative (our quadrature against radiosim's).
    t_int, gain, tau, t_i = 1e-3, 0.0014, 0.8, 310.0
    scene = scene_for(600.0)
    cold = grey_lens_camera(None).measure(scene, t_int)
    warm = grey_lens_camera(t_i).measure(scene, t_int)
    camera = grey_lens_camera(t_i)
    fpa = camera.fpa
    etendue = math.pi * fpa.fill_factor * fpa.pixel_pitch**2 * 0.2**2
    assert camera.etendue == pytest.approx(etendue, rel=1e-12)
    rad = Radiometry(camera)
    filter_qe = float(integrate.simpson(rad.filter * rad.qe * rad.planck(t_i), x=rad.wavelength))
    expected = (1 - tau) * filter_qe * etendue * t_int * gain
    assert expected > 1.0  # many counts: the emission matters at 1 ms
    np.testing.assert_allclose(warm.counts - cold.counts, expected, rtol=1e-6)
    # Calibrated at its own instrument temperature, the camera subtracts it: no bias.
    np.testing.assert_allclose(warm.apparent_temperature, 600.0, atol=1e-6)
    np.testing.assert_allclose(cold.apparent_temperature, 600.0, atol=1e-6)


@pytest.mark.parametrize("assumed", [290.0, 330.0])
def test_calibration_at_another_instrument_temperature_biases_by_the_arithmetic(assumed):
    # Optics at 310 K, calibration made at 290 or 330 K: the camera subtracts E(assumed)
    # instead of E(310 K), so L(T_a) = L(T) + E(310) − E(assumed). Table precision: 1e-3 K.
    t = 400.0
    camera = grey_lens_camera(310.0, assumed)
    m = camera.measure(scene_for(t), 1e-3)
    rad = Radiometry(camera)
    expected = rad.temperature(rad.L(t) + rad.emission(310.0) - rad.emission(assumed))
    assert abs(expected - t) > 0.5
    np.testing.assert_allclose(m.apparent_temperature, expected, atol=1e-3, rtol=0)


def test_optics_emission_carries_shot_noise():
    # The emitted photons are counted like any others: with shot noise (K = 1 DN/e⁻, no
    # read noise) the variance of 60 × 60 pixels of a uniform scene equals their mean
    # charge, emission included. The sample variance of n = 3600 Poisson values has relative
    # standard deviation √(2/n) ≈ 2.4 % (large means): 4σ ≈ 10 % asserted. Without the
    # emission's noise the ratio would be L/(L + E) ≈ 0.5.
    scene = UniformBlackbody(300.0, shape=(60, 60), dx=6e-6, dt=1e-3)
    camera = grey_lens_camera(330.0, electronics=Electronics(shot_noise=True))
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, shape=None))
    m = camera.measure(scene, 1e-3, rng=7)
    rad = Radiometry(camera)
    emission_share = rad.emission(330.0) / (rad.L(300.0) + rad.emission(330.0))
    assert emission_share > 0.3
    assert m.counts.size == 3600
    assert np.var(m.counts, ddof=1) / np.mean(m.counts) == pytest.approx(1.0, rel=0.1)


# -- 9. bad inputs and camera files ----------------------------------------------------------


def test_bad_environments_are_refused():
    scene = UniformBlackbody(500.0, shape=(4, 4), n_frames=3)
    with pytest.raises(RadiosimError, match="reflected_temperature must be finite "
                                            "temperatures > 0 K, got -5"):
        scene.set_environment(reflected_temperature=-5.0)
    with pytest.raises(RadiosimError, match=r"path_transmission must be in \(0, 1\], got 0"):
        scene.set_environment(path_transmission=0.0)
    with pytest.raises(RadiosimError, match="path_transmission"):
        scene.set_environment(path_transmission=1.2)
    with pytest.raises(RadiosimError, match="needs its path_temperature"):
        scene.set_environment(path_transmission=0.9)
    with pytest.raises(RadiosimError, match=r"map has shape \(3, 4\), expected.*\(4, 4\)"):
        scene.set_environment(reflected_temperature=np.full((3, 4), 300.0))
    with pytest.raises(RadiosimError, match="per frame has 2 values.*3"):
        scene.set_environment(reflected_temperature=[300.0, 310.0])
    with pytest.raises(RadiosimError, match="surroundings_temperature"):
        scene.set_environment(surroundings_temperature=float("nan"))


def test_bad_camera_settings_are_refused():
    with pytest.raises(RadiosimError, match="assumed_reflected_temperature"):
        camera_for(assumed_reflected_temperature=-5.0)
    with pytest.raises(RadiosimError, match="assumed_path_transmission"):
        camera_for(assumed_path_transmission=0.0, assumed_path_temperature=300.0)
    with pytest.raises(RadiosimError, match="assumed_path_temperature"):
        camera_for(assumed_path_transmission=0.9)
    with pytest.raises(RadiosimError, match="assumed_instrument_temperature"):
        camera_for(assumed_instrument_temperature=0.0)
    with pytest.raises(RadiosimError, match="instrument_temperature"):
        camera_for({"instrument_temperature": -300.0})
    response = camera_for().response_model
    with pytest.raises(RadiosimError, match="path transmission"):
        Calibration(response, Electronics.ideal(), 1.0, 1e-3, path_transmission=0.0)
    with pytest.raises(RadiosimError, match="assumed reflected temperature"):
        Calibration(response, Electronics.ideal(), 1.0, 1e-3, reflected_temperature=-1.0)


def test_camera_file_round_trip_keeps_the_thermography_settings(tmp_path):
    camera = camera_for({"instrument_temperature": 305.0}, assumed_emissivity=0.7,
                        assumed_reflected_temperature=330.0, assumed_path_transmission=0.9,
                        assumed_path_temperature=300.0, assumed_instrument_temperature=301.0)
    path = tmp_path / "camera.toml"
    path.write_text(camera.to_toml())
    back = rs.Camera.from_toml(path)
    for name in ("assumed_emissivity", "assumed_reflected_temperature",
                 "assumed_path_transmission", "assumed_path_temperature",
                 "assumed_instrument_temperature"):
        assert getattr(back, name) == getattr(camera, name), name
    assert back.optics.instrument_temperature == 305.0
    scene = scene_for(800.0, 0.7, reflected_temperature=330.0, path_transmission=0.9,
                      path_temperature=300.0)
    np.testing.assert_array_equal(back.measure(scene, 1e-4).apparent_temperature,
                                  camera.measure(scene, 1e-4).apparent_temperature)


def test_a_spectral_emissivity_reflects_its_own_complement():
    # A surface whose emissivity falls across the band (0.8 at 3.8 µm to 0.3 at 5.1 µm) in a
    # 600 K room: the image stage's signal is ∫ (ε(λ) L_λ(T) + (1 − ε(λ)) L_λ(T_refl)) through
    # filter × optics × QE, by our own quadrature, to the radiance tables' 1e-6 (a grey 1 − ε
    # of the mean ε, or a missing reflection, is off by percents here).
    from radiosim.spectral import colour_science

    camera = camera_for()
    lo, hi = camera.optics.band
    nodes = np.linspace(lo, hi, 14)  # [m]: radiosim's curves are in metres
    values = np.interp(nodes, [lo, hi], [0.8, 0.3])
    curve = colour_science().SpectralDistribution(dict(zip(nodes, values)))
    t, t_refl = 900.0, 600.0
    scene = scene_for(t, curve, reflected_temperature=t_refl)
    m = camera.measure(scene, 1e-4)
    rad = Radiometry(camera)
    eps = np.interp(rad.wavelength, nodes, values)
    weight = rad.filter * rad.optics * rad.qe
    expected = (rad._integral(weight * eps, t) + rad._integral(weight * (1 - eps), t_refl))
    np.testing.assert_allclose(m.signal_mean, expected, rtol=1e-6)
    grey = float(np.mean(eps))
    for wrong in (rad._integral(weight * eps, t) + (1 - grey) * rad.L(t_refl),
                  rad._integral(weight * eps, t)):
        assert abs(wrong / expected - 1) > 100 * 1e-6


def test_a_spectral_emissivity_in_nanometres_is_refused_not_misread():
    # The same curve with its wavelengths in nm (3750–5150) passed as metres: refused in one
    # line naming the unit slip (it measured 32 % off the truth before, silently).
    from radiosim.spectral import colour_science

    lo, hi = camera_for().optics.band
    nodes = np.linspace(lo * 1e9, hi * 1e9, 14)  # [nm], not metres
    curve = colour_science().SpectralDistribution(dict(zip(nodes, np.full(14, 0.5))))
    with pytest.raises(RadiosimError, match=r"emissivity: its wavelengths run 3750–5150; "
                                            r"wavelengths are in metres") as info:
        scene_for(900.0, curve)
    assert "\n" not in str(info.value)

"""
The real focal-plane array (issue 12) against independent references.

Every reference here is written out in the test: an EMVA 1288 spatial analysis of our own, the
two-point NUC and the quadratic non-linearity e·(1 − β e/FW) applied by hand to the pattern maps,
a Planck quadrature of our own over the shipped CSV curves (read with numpy, interpolated
linearly as the curves are defined), the étendue of the working cone written out, the EMVA 1288
linearity error of our own, a hand-computed bad-pixel median, and the subframes of a superframe
replicated by measuring them one by one with the same generator. Every tolerance states where
it comes from: rounding, the tables' accuracy, or the sampling statistics of the estimate
(k = 4 standard errors unless said otherwise, seeds fixed).

Cameras are the nist-ir preset (120 × 160 InSb pixels, 14 bit, K = 1.398e-3 DN/e⁻, read noise
600 e⁻, full well 1.1e7 e⁻) with the array's effects switched on through ``dataclasses.replace``.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import tomllib
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

import radiosim
from radiosim import Camera, FrameStack, UniformBlackbody
from radiosim.calibration import NonUniformityCorrection, replace_bad_pixels
from radiosim.acquisition import frame_period, record, superframe
from radiosim.characterization import (flat_field, flat_fields, fit_nuc, linearity_error,
                                       measurable_range, netd, residual_nonuniformity,
                                       spatial_nonuniformity)
from radiosim.electronics import Electronics, apply_nonlinearity, invert_nonlinearity
from radiosim.errors import RadiosimError
from radiosim.fpa import FocalPlaneArray
from radiosim.radiometry import band_radiance
from radiosim.spectral import spectra_directory

T_INT = 240e-6  # [s]; nist-ir fills its well at ≈ 664 K here
K_SIGMA = 4.0  # standard errors allowed for a statistical comparison (fixed seeds)
ignore_saturation = pytest.mark.filterwarnings("ignore::radiosim.errors.RadiosimWarning")


# -- cameras -------------------------------------------------------------------------------------


@lru_cache(maxsize=None)
def nist() -> Camera:
    return Camera.preset("nist-ir")


def camera_with(fpa=None, electronics=None, base: Camera | None = None, **camera) -> Camera:
    """nist-ir (or ``base``) with some FPA, electronics and camera fields changed."""
    base = base or nist()
    return base.replace(
        fpa=dataclasses.replace(base.fpa, **(fpa or {})),
        electronics=dataclasses.replace(base.electronics, **(electronics or {})), **camera)


def quiet(camera: Camera) -> Camera:
    """The camera with noise-free, unquantised electronics (full well and β kept)."""
    return camera_with(base=camera, electronics=dict(shot_noise=False, read_noise=0.0,
                                                     adc_bits=None))


# -- our own radiometry --------------------------------------------------------------------------

_H, _C, _KB = 6.62607015e-34, 299792458.0, 1.380649e-23  # SI 2019, exact


def _read_curve(name: str):
    """A shipped CSV curve read with the csv module: wavelengths [m], values [1]."""
    path = spectra_directory() / f"{name}.csv"
    lines = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    rows = list(csv.reader(lines[1:]))
    unit = {"um": 1e-6, "nm": 1e-9, "m": 1.0}[
        next(ln.split(":", 1)[1].strip() for ln in path.read_text().splitlines()
             if ln.startswith("# wavelength_unit"))]
    data = np.array(rows, dtype=float)
    return data[:, 0] * unit, data[:, 1]


class OwnBand:
    """
    In-band photon radiance L(T) and dL/dT of the nist-ir preset, from its TOML and the CSV
    curves alone: the product of the (linearly interpolated, zero outside) filter, lens and QE
    curves times Planck's photon radiance, by 10-point Gauss–Legendre on every interval between
    the curves' nodes (the integrand is a cubic times a smooth exponential there: the error is
    far below 1e-12 relative). dL/dT is the analytic derivative, L_λ · x eˣ/(eˣ − 1) / T with
    x = hc/(λkT), not a difference.
    """

    def __init__(self, preset="nist-ir"):
        toml = tomllib.loads((Path(radiosim.__file__).parent / "presets" /
                              f"{preset}.toml").read_text())
        optics, fpa = toml["optics"], toml["fpa"]
        lo, hi = (v * 1e-6 for v in optics["band_um"])
        curves = [_read_curve(optics[k]) for k in ("spectral_filter", "transmission")]
        curves.append(_read_curve(fpa["quantum_efficiency"]))
        edges = np.unique(np.concatenate([[lo, hi]] + [w[(w > lo) & (w < hi)]
                                                       for w, _ in curves]))
        x, w = np.polynomial.legendre.leggauss(10)
        a, b = edges[:-1, None], edges[1:, None]
        self.lam = (0.5 * (b - a) * x + 0.5 * (a + b)).ravel()  # [m]
        self.weights = (0.5 * (b - a) * w).ravel()  # [m]
        for wavelength, value in curves:
            self.weights = self.weights * np.interp(self.lam, wavelength, value, 0.0, 0.0)
        # Étendue of the working cone: sin θ' = NA/m on the image side; G = A_active π sin²θ'.
        magnification = fpa["detector_pitch_um"] / fpa["pixel_pitch_um"]
        sine = optics["objective_na"] / magnification
        if optics["f_number"] < 1 / (2 * math.tan(math.asin(sine))):  # the cold stop is wider
            self.etendue = fpa["fill_factor"] * (fpa["detector_pitch_um"] * 1e-6) ** 2 \
                * math.pi * sine**2  # [m² sr]
        else:  # pragma: no cover - not the nist-ir case
            raise AssertionError("the cold stop limits the cone")

    def _spectral(self, temperature):
        t = np.asarray(temperature, dtype=float)[..., None]
        x = _H * _C / (self.lam * _KB * t)
        return 2 * _C / self.lam**4 / np.expm1(x), x, t

    def radiance(self, temperature):
        """L_q(T) [photons s⁻¹ m⁻² sr⁻¹]."""
        spectral, _, _ = self._spectral(temperature)
        return spectral @ self.weights

    def slope(self, temperature):
        """dL_q/dT [photons s⁻¹ m⁻² sr⁻¹ K⁻¹]."""
        spectral, x, t = self._spectral(temperature)
        return (spectral * x / -np.expm1(-x) / t) @ self.weights

    def photoelectrons(self, temperature, integration_time):
        """Mean photo-charge of a blackbody filling a pixel [e⁻] (cold optics)."""
        return self.radiance(temperature) * self.etendue * integration_time


@lru_cache(maxsize=None)
def own_band() -> OwnBand:
    return OwnBand()


def temperature_for_charge(fraction, integration_time=T_INT):
    """The blackbody temperature [K] whose photo-charge is ``fraction`` of the full well."""
    from scipy.optimize import brentq

    target = fraction * nist().electronics.full_well
    return brentq(lambda t: own_band().photoelectrons(t, integration_time) - target, 150.0,
                  3000.0, xtol=1e-9)


def test_own_radiometry_matches_the_camera():
    # Our quadrature and radiosim's (Gauss on the same node intervals) agree to rounding; the
    # Planck table the camera uses is good to 1e-8 relative (its docstring; tests assert 1e-6).
    band, camera = own_band(), nist()
    t = np.array([250.0, 450.0, 650.0, 1200.0])
    np.testing.assert_allclose(band.radiance(t), band_radiance(t, camera.optics.band, "photon",
                                                               camera.responsivity), rtol=1e-10)
    np.testing.assert_allclose(band.radiance(t), camera.response_model.grey_signal(t),
                               rtol=1e-6)
    assert band.etendue == pytest.approx(camera.etendue, rel=1e-12)
    assert camera.optics.instrument_temperature is None  # cold optics: no emission to add


# -- 1. EMVA 1288 spatial analysis ----------------------------------------------------------------


def emva_spatial(dark: np.ndarray, bright: np.ndarray, gain: float) -> dict:
    """
    Our EMVA 1288 (Release 4, §4.5/§8) spatial analysis of L dark and L bright frames [DN]:
    the spatial variance of the L-frame mean image, less the temporal variance it still holds
    (σ²_t / L, σ²_t estimated from successive-frame differences, ½⟨(y_k+1 − y_k)²⟩, which is
    unbiased for white temporal noise and independent of the fixed pattern), then
    DSNU = s_dark / K [e⁻] and PRNU = √(s²_bright − s²_dark) / (μ_bright − μ_dark) [1].
    """
    out = {}
    for name, frames in (("dark", dark), ("bright", bright)):
        frames = np.asarray(frames, dtype=float)
        n_frames, n_pixels = frames.shape[0], frames[0].size
        mean_image = frames.sum(axis=0) / n_frames
        spatial = np.sum((mean_image - mean_image.mean()) ** 2) / (n_pixels - 1)
        temporal = np.sum(np.diff(frames, axis=0) ** 2) / (2 * (n_frames - 1) * n_pixels)
        out[name] = dict(s2=spatial - temporal / n_frames, temporal=temporal,
                         mean=mean_image.mean())
    signal = out["bright"]["mean"] - out["dark"]["mean"]
    return dict(dsnu=math.sqrt(out["dark"]["s2"]) / gain,
                prnu=math.sqrt(out["bright"]["s2"] - out["dark"]["s2"]) / signal, **out)


def test_emva_spatial_analysis_recovers_configured_dsnu_and_prnu():
    prnu, dsnu, frames, seed = 0.01, 3000.0, 16, 2024
    camera = camera_with(fpa=dict(prnu=prnu, dsnu=dsnu, pattern_seed=11))
    el = camera.electronics
    K, n = el.gain, camera.fpa.shape[0] * camera.fpa.shape[1]
    level = temperature_for_charge(0.5)  # EMVA: the bright level near half saturation
    rng = np.random.default_rng(seed)  # the order radiosim's analysis draws them in
    dark, _ = flat_fields(camera, None, T_INT, frames, rng)
    bright, saturated = flat_fields(camera, level, T_INT, frames, rng)
    assert not saturated.any()
    own = emva_spatial(dark, bright, K)

    # Sampling uncertainty. The pattern is a draw of N = 19200 pixels, so its sample variance
    # has var 2σ⁴/(N − 1) (a sample std's relative standard error 1/√(2(N − 1)) = 0.51 %); the
    # mean image adds σ²_t/L of temporal variance per pixel, and the subtracted σ̂²_t/L has
    # var 2σ⁴_t/(L²(L − 1)N) (σ̂²_t from (L − 1)N differences).
    D = el.dark_current * T_INT  # [e⁻]
    x = own_band().photoelectrons(level, T_INT)  # [e⁻]
    var_dark = K**2 * (D + el.read_noise**2) + 1 / 12  # temporal [DN²], model
    var_bright = K**2 * (x + D + el.read_noise**2) + 1 / 12
    s2_d = (K * dsnu) ** 2  # [DN²]
    se_s2_dark = math.sqrt(2 * (s2_d + var_dark / frames) ** 2 / (n - 1)
                           + 2 * var_dark**2 / (frames**2 * (frames - 1) * n))
    rel_se_dsnu = se_s2_dark / (2 * s2_d)  # δs/s = δs²/(2 s²)
    assert own["dsnu"] == pytest.approx(dsnu, rel=K_SIGMA * rel_se_dsnu)  # ≈ 2 %
    # PRNU: s²_bright − s²_dark = s²_P + 2 c_PD + noise, with s²_P the sample variance of the
    # gain map × signal (var 2σ_P⁴/(N − 1)), c_PD the sample covariance of the independent
    # PRNU and DSNU maps (var σ_P²σ_D²/N), and the temporal parts of both images.
    s2_p = (K * prnu * x) ** 2
    var_s2p = (2 * s2_p**2 / (n - 1) + 4 * s2_p * (s2_d + var_bright / frames) / n
               + 2 * (var_bright / frames) ** 2 / n + se_s2_dark**2
               + 2 * var_bright**2 / (frames**2 * (frames - 1) * n))
    rel_se_prnu = math.sqrt(var_s2p) / (2 * s2_p) + prnu / math.sqrt(n)  # + the mean gain's
    assert own["prnu"] == pytest.approx(prnu, rel=K_SIGMA * rel_se_prnu)  # ≈ 2 %
    # The temporal correction matters at this level and was estimated right: our σ̂²_t agree
    # with the noise model within their own sampling error √(2/((L − 1)N)) (+ the dither of the
    # 1 DN steps, which the 1/12 term models only approximately: 1 % slack).
    assert own["dark"]["temporal"] == pytest.approx(var_dark, rel=K_SIGMA * math.sqrt(
        2 / ((frames - 1) * n)) + 0.01)
    assert own["bright"]["temporal"] == pytest.approx(var_bright, rel=K_SIGMA * math.sqrt(
        2 / ((frames - 1) * n)) + 0.01)

    # radiosim's analysis of the same frames (same seed, same draw order). It estimates σ²_t by
    # the per-pixel variance instead of differences: both unbiased, each with relative standard
    # error ≲ √(3/((L − 1)N)) = 0.36 %, and σ²_t/L is ≤ 0.3 % of s²_dark and ≤ 0.02 % of s²_bright,
    # so the two differ by ≲ 1e-5 relative: 1e-4 allowed.
    theirs = spatial_nonuniformity(camera, level, T_INT, K, frames=frames, rng=seed)
    assert theirs.defects == 0
    assert theirs.dsnu == pytest.approx(own["dsnu"], rel=1e-4)
    assert theirs.prnu == pytest.approx(own["prnu"], rel=1e-4)


# -- 2. non-uniformity correction ------------------------------------------------------------------


def test_two_point_nuc_leaves_temporal_noise_at_its_points():
    nuc_frames = 4  # few flats, so that their noise shows: √(1 + 1/L) = 1.118
    camera = camera_with(fpa=dict(prnu=0.02, dsnu=3000.0, pattern_seed=5))
    t1, t2 = 500.0, 600.0  # ≈ 20 % and 60 % of the well at 240 µs
    corrected_camera = fit_nuc(camera, [t1, t2], T_INT, frames=nuc_frames, rng=7)
    nuc = corrected_camera.nuc
    good = ~nuc.bad
    n = int(good.sum())
    assert n == good.size  # no dead, hot or outlying pixels configured
    m = 8  # frames for the temporal noise level
    rng = np.random.default_rng(8)  # a stream independent of the NUC's flats (seed 7)
    for t in (t1, t2):
        raw, saturated = flat_fields(camera, t, T_INT, m, rng)
        assert not saturated.any()
        corrected = np.stack([nuc.apply(frame) for frame in raw])
        spatial = np.std(corrected[0][good], ddof=1)  # one corrected frame [DN]
        temporal = math.sqrt(np.mean(np.var(corrected, axis=0, ddof=1)[good]))
        # Derivation: pixel i reads μ_i + n_i; the NUC holds p_i = μ_i + m_i (mean of L flats,
        # var(m_i) = σ_i²/L) and maps c_i = t₁ + (y − p_i)·s_i with s_i its gain. At the point,
        # c_i − t₁ = s_i (n_i − m_i): spatial variance ⟨s_i² σ_i²⟩ (1 + 1/L), temporal variance
        # ⟨s_i² σ_i²⟩. So spatial / temporal = √(1 + 1/L) exactly in expectation, whatever the
        # gains (at L = 4: 1.118; √(1 + 2/L) would be 1.225).
        expected = math.sqrt(1 + 1 / nuc_frames)
        # Standard errors: a sample variance of N Gaussian values √(2/(N − 1)); the temporal
        # mean of N per-pixel variances of M frames √(2/((M − 1)N)); halved for the std ratio.
        rel_se = 0.5 * math.sqrt(2 / (n - 1) + 2 / ((m - 1) * n))  # 0.55 %
        assert spatial / temporal == pytest.approx(expected, rel=K_SIGMA * rel_se)
        # The temporal level itself is the noise model's, through the NUC's gains s_i ≈ 1/g_i
        # (⟨s²σ²⟩ differs from σ̄² by ≈ PRNU² = 0.04 %; 1 % slack for the ADC's dither).
        el = camera.electronics
        sigma = math.sqrt(el.gain**2 * (own_band().photoelectrons(t, T_INT)
                                        + el.dark_current * T_INT + el.read_noise**2) + 1 / 12)
        assert temporal == pytest.approx(sigma, rel=K_SIGMA * math.sqrt(
            2 / ((m - 1) * n)) + 0.01)
        # Without the NUC the fixed pattern dominates (PRNU 2 % of ≈ 3000 DN ≈ 60 DN).
        assert np.std(raw[0], ddof=1) > 10 * spatial


def _predicted_mean_counts(camera: Camera, pattern, photo):
    """Noise-free mean counts [DN] of every pixel for a mean photo-charge ``photo`` [e⁻]:
    e = g·x + D + d (Poisson part g·x + D, variance the same), signal e·(1 − β_ij e/FW) with
    E[e²] = ē² + var, then offset + K·signal (the ADC's rounding is unbiased under ≈ 4 DN of
    noise: its bias is of order exp(−2π²σ²) ≈ 0)."""
    el = camera.electronics
    poisson = pattern.gain * photo + el.dark_current * T_INT  # [e⁻], also its variance
    mean = poisson + pattern.dark  # [e⁻]
    beta = el.nonlinearity * pattern.nonlinearity
    signal = mean - beta * (mean**2 + poisson) / el.full_well  # [e⁻ eq.]
    return el.offset + el.gain * signal, poisson, beta, mean


def test_nuc_residual_rises_away_from_its_points_as_the_quadratic_model_predicts():
    camera = camera_with(fpa=dict(prnu=0.01, dsnu=3000.0, nonlinearity_spread=0.3,
                                  pattern_seed=9),
                         electronics=dict(nonlinearity=0.05))
    t1, t2, nuc_frames, frames = 500.0, 600.0, 16, 16
    camera = fit_nuc(camera, [t1, t2], T_INT, frames=nuc_frames, rng=3)
    nuc = camera.nuc
    good = ~nuc.bad
    n = int(good.sum())
    temperatures = np.array([450.0, 500.0, 550.0, 600.0, 635.0, 650.0])
    measured = residual_nonuniformity(camera, temperatures, T_INT, frames=frames, rng=4)

    el = camera.electronics
    pattern = camera.fpa.pattern(camera.fpa.shape)
    points = [_predicted_mean_counts(camera, pattern, own_band().photoelectrons(t, T_INT))[0]
              for t in (t1, t2)]
    targets = [p[good].mean() for p in points]
    for t, value in zip(temperatures, measured):
        counts, poisson, beta, mean = _predicted_mean_counts(
            camera, pattern, own_band().photoelectrons(t, T_INT))
        gain = (targets[1] - targets[0]) / (points[1] - points[0])  # the NUC's s_i
        corrected = targets[0] + (counts - points[0]) * gain  # the two-point map, extrapolated
        r2 = np.var(corrected[good], ddof=1)  # [DN²], the model's residual
        # What the NUC's own flats add: c = c₀ − s[(1 − w) m₁ + w m₂], w = (y − p₁)/(p₂ − p₁),
        # var(m_k) = σ_k²/L with σ² = K²(c'² var_shot + σ_r²) + 1/12, c' = 1 − 2βē/FW the
        # conversion's slope.
        sig2 = []
        for tk in (t1, t2):
            _, pk, bk, mk = _predicted_mean_counts(camera, pattern,
                                                   own_band().photoelectrons(tk, T_INT))
            slope = 1 - 2 * bk * mk / el.full_well
            sig2.append(el.gain**2 * (slope**2 * pk + el.read_noise**2) + 1 / 12)
        w = (counts - points[0]) / (points[1] - points[0])
        flat2 = np.mean((gain**2 * ((1 - w) ** 2 * sig2[0] + w**2 * sig2[1]) / nuc_frames)[good])
        slope = 1 - 2 * beta * mean / el.full_well
        sigma2 = np.mean((gain**2 * (el.gain**2 * (slope**2 * poisson + el.read_noise**2)
                                     + 1 / 12))[good])  # the measured frames' temporal [DN²]
        # Standard error of the measured variance (residual_nonuniformity: spatial variance of
        # an F-frame mean less σ̂²/F): the Gaussian parts (σ²/F + flat noise) have sample-
        # variance error √(2/N)·(their variance); their cross term with the fixed residual has
        # std 2√(r²·(σ²/F + flat²)/N); the subtracted σ̂²/F has √(2/((F − 1)N))·σ²/F.
        noise2 = sigma2 / frames + flat2
        se = (math.sqrt(2 / n) * noise2 + 2 * math.sqrt(r2 * noise2 / n)
              + math.sqrt(2 / ((frames - 1) * n)) * sigma2 / frames)
        assert value**2 == pytest.approx(r2 + flat2, abs=K_SIGMA * se), t
        if t in (t1, t2):
            # At its points the NUC leaves only its flats' noise: σ/√L ≈ 1 DN, no residual.
            assert r2 < 1e-12
    # The curve: flat-noise level at the points, rising on both sides (β spread 1.5 %: at
    # 650 K, 0.9 FW, the chord misses by β_ij (e − e₁)(e − e₂)/FW ≈ 0.015 · 0.21 FW ≈ 48 DN).
    assert measured[0] > 3 * measured[1] and measured[2] > measured[1]
    assert measured[3] < measured[4] < measured[5] and measured[5] > 20 * measured[3]


# -- 3. non-linearity ------------------------------------------------------------------------------


@pytest.mark.parametrize("beta", [1e-6, 0.01, 0.05, 0.2, 0.49])
def test_invert_nonlinearity_undoes_apply_nonlinearity(beta):
    full = 1.1e7
    e = np.linspace(0.0, full, 2001)  # the rising branch up to the well (top at FW/(2β) ≥ FW)
    y = apply_nonlinearity(e, beta, full)
    np.testing.assert_array_equal(y, e * (1 - beta * e / full))
    # Rounding: a few ulp in y, amplified by the inverse's condition 1/c' with
    # c' = 1 − 2βe/FW ≥ 1 − 2β (the curve's slope): 64 ulp / (1 − 2β) relative.
    rtol = 64 * np.finfo(float).eps / (1 - 2 * beta)
    np.testing.assert_allclose(invert_nonlinearity(y, beta, full), e, rtol=rtol, atol=1e-9)
    s = np.linspace(0.0, full * (1 - beta), 2001)
    np.testing.assert_allclose(apply_nonlinearity(invert_nonlinearity(s, beta, full), beta,
                                                   full), s, rtol=rtol, atol=1e-9)
    # Past the curve's top, FW/(4β), no charge gives the signal.
    assert np.isnan(invert_nonlinearity(full / (4 * beta) * 1.001, beta, full))


def test_zero_nonlinearity_is_the_identity():
    e = np.array([0.0, 1.0, 5e6])
    assert apply_nonlinearity(e, 0.0, 1.1e7) is e
    assert invert_nonlinearity(e, 0.0, 1.1e7) is e
    assert apply_nonlinearity(e, 0.05, None) is e  # without a well nothing bends


def test_calibration_inverts_the_nonlinear_curve_exactly():
    beta = 0.05
    camera = quiet(camera_with(electronics=dict(nonlinearity=beta)))
    el = camera.electronics
    linear = camera_with(base=camera, electronics=dict(nonlinearity=0.0))
    for t in (200.0, 300.0, 450.0, 550.0, 620.0, 650.0):  # up to 0.9 FW at 240 µs
        scene = UniformBlackbody(t, shape=(120, 160), dx=6e-6, dt=T_INT)
        m = camera.measure(scene, T_INT, 0.0, rng=0)
        # The counts follow the closed-form curve (our radiance; the camera's table is good to
        # 1e-8 relative, and the mean over the footprint of a uniform signal to rounding).
        e = own_band().photoelectrons(t, T_INT) + el.dark_current * T_INT
        np.testing.assert_allclose(m.counts, el.offset + el.gain * e * (1 - beta * e /
                                                                        el.full_well), rtol=1e-7)
        # Inversion: the table's Newton inverse converges to rounding and the stable root of
        # the quadratic loses a few ulp: far below 1e-6 K.
        assert m.valid.all()
        np.testing.assert_allclose(m.apparent_temperature, t, rtol=0, atol=1e-6)
        # Teeth: a calibration that ignored the bend would read low by kelvins at the top.
        if t >= 600:
            assert t - linear.calibration(T_INT).temperature(m.counts).max() > 1.0


def own_linearity_error(exposure, signal, low=0.05, high=0.95) -> float:
    """EMVA 1288 (Release 3.0, §6.6): a least-squares line through the (exposure, signal above
    dark) points between 5 % and 95 % of the signal's maximum; δ_i = 100 (y_i − fit_i) /
    ((high − low) y_max); LE = (max δ − min δ)/2 [%]."""
    x, y = np.asarray(exposure, float), np.asarray(signal, float)
    top = y.max()
    used = (y >= low * top) & (y <= high * top)
    design = np.column_stack([x[used], np.ones(used.sum())])
    coefficients, *_ = np.linalg.lstsq(design, y[used], rcond=None)
    delta = 100 * (y[used] - design @ coefficients) / ((high - low) * top)
    return float((delta.max() - delta.min()) / 2)


def test_linearity_error_of_a_simulated_sweep_is_the_closed_form_curves():
    beta, frames = 0.05, 4
    camera = camera_with(electronics=dict(nonlinearity=beta))
    el = camera.electronics
    fractions = np.array([0.02, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.87, 0.95])
    temperatures = [temperature_for_charge(f) for f in fractions]
    exposure = np.array([own_band().photoelectrons(t, T_INT) for t in temperatures])  # [e⁻]
    rng = np.random.default_rng(12)
    dark = flat_field(camera, None, T_INT, frames, rng)[0].mean()
    means = []
    for t in temperatures:
        flat, saturated = flat_field(camera, t, T_INT, frames, rng)
        assert not saturated.any()
        means.append(flat.mean())
    means = np.array(means)
    simulated = linearity_error(exposure, means, dark)

    D = el.dark_current * T_INT

    def curve(x):  # mean counts: E[e(1 − βe/FW)] for Poisson e of mean x + D
        e = x + D
        return el.offset + el.gain * (e - beta * (e**2 + e) / el.full_well)

    closed = own_linearity_error(exposure, curve(exposure) - curve(0.0))
    # Both use the same levels: none lies near the 5 % or 95 % cut (margin ≫ the noise).
    y = curve(exposure) - curve(0.0)
    assert np.min(np.abs(y / y.max() - 0.05)) > 1e-3 and np.min(np.abs(y / y.max() - 0.95)) > 1e-3
    # Each simulated mean has the noise of N·L = 76800 readings, σ ≤ 4.7 DN → ≤ 0.017 DN, so
    # |ε| ≤ 4σ ≈ 0.07 DN; a perturbation ε moves each δ by ≤ 100·ε(1 + leverage ≤ 2)/(0.9 y_max)
    # and LE by at most that: ≤ 100 · 3 · 0.07 / (0.9 · 14000) ≈ 2e-3 % (LE itself ≈ 0.5 %).
    sigma = math.sqrt(el.gain**2 * (el.full_well + el.read_noise**2) + 1 / 12)
    eps = K_SIGMA * sigma / math.sqrt(camera.fpa.shape[0] * camera.fpa.shape[1] * frames)
    assert simulated == pytest.approx(closed, abs=100 * 3 * eps / (0.9 * y.max()))
    assert closed > 0.3  # a 5 % bend at full well is visible
    # radiosim's linearity_error and ours agree on the same numbers to rounding.
    assert linearity_error(exposure, curve(exposure), curve(0.0)) == pytest.approx(closed,
                                                                                    rel=1e-9)


# -- 4. NETD --------------------------------------------------------------------------------------


def own_netd(camera: Camera, temperature, integration_time, beta: float = 0.0):
    """
    σ_temporal / (dS/dT) from our radiometry, referred to the charge: the shot noise of the
    mean charge (photo + dark), and the read and quantisation (1/12 DN² → 1/(12K²) e⁻²) noise,
    which are added after the conversion and so count 1/c'² in charge, c' = 1 − 2βe/FW being
    the conversion's slope (1 when linear); over de/dT = G·t·dL/dT.
    """
    el, band = camera.electronics, own_band()
    e = band.photoelectrons(temperature, integration_time) + el.dark_current * integration_time
    slope = 1 - 2 * beta * e / el.full_well if beta else 1.0
    noise2 = e + (el.read_noise**2 + 1 / (12 * el.gain**2)) / slope**2  # [e⁻²]
    return np.sqrt(noise2) / (band.etendue * integration_time * band.slope(temperature))


def test_netd_is_temporal_noise_over_the_radiometric_slope():
    camera = nist()
    for t_int, temperatures in ((T_INT, [250.0, 400.0, 500.0, 600.0, 650.0]),
                                (40e-6, [400.0, 800.0, 1000.0])):
        t = np.array(temperatures)
        # 1e-4: our quadrature matches to rounding; the camera differentiates its ln L spline
        # (1e-8 relative) by a central difference of h = 1e-4 T, whose truncation error is
        # h² L'''/(6 L') ≈ h² (b/T²)²/6 ≈ 3e-7 (b = hc/λk ≈ 3300 K).
        np.testing.assert_allclose(netd(camera, t, t_int), own_netd(camera, t, t_int), rtol=1e-4)
    low, saturation = measurable_range(camera, T_INT)
    assert np.isnan(netd(camera, saturation + 1.0, T_INT))  # beyond the range: none


@ignore_saturation
@pytest.mark.parametrize("beta, temperature", [(0.0, 450.0), (0.0, 600.0), (0.3, 635.0)])
def test_netd_monte_carlo(beta, temperature):
    """The spread of apparent temperature over noisy read-outs of a uniform blackbody is the
    NETD: for the linear camera radiosim's and ours; for a strongly bent one (β = 0.3) ours,
    with read and quantisation noise referred through the conversion's slope."""
    camera = camera_with(electronics=dict(nonlinearity=beta))
    scene = UniformBlackbody(temperature, shape=(120, 160), dx=6e-6, dt=T_INT)
    rng = np.random.default_rng(21)
    readings = np.concatenate([camera.measure(scene, T_INT, 0.0, rng).apparent_temperature
                               .ravel() for _ in range(4)])
    assert np.isfinite(readings).all()
    n = readings.size
    # A sample std of n = 76800 Gaussian readings has relative standard error 1/√(2(n − 1))
    # = 0.26 %. The inverse curve's curvature over ±4 NETD (≈ 0.2 K, against ln L's scale
    # T²/b ≈ 100 K) changes the spread by < 1e-5; the 1 DN steps are dithered by ≈ 4 DN of noise.
    expected = own_netd(camera, temperature, T_INT, beta)
    assert np.std(readings, ddof=1) == pytest.approx(expected, rel=K_SIGMA / math.sqrt(2 * (n - 1)))
    if beta == 0:
        assert netd(camera, temperature, T_INT) == pytest.approx(expected, rel=1e-4)


def test_netd_of_a_nonlinear_camera():
    t = np.array([450.0, 550.0, 600.0, 635.0, 650.0])
    for beta in (0.05, 0.3):
        camera = camera_with(electronics=dict(nonlinearity=beta))
        np.testing.assert_allclose(netd(camera, t, T_INT), own_netd(camera, t, T_INT, beta),
                                   rtol=1e-4)


# -- 5. superframing -------------------------------------------------------------------------------


def _hot_spot_scene(n_frames=6):
    """Constant frames of 3 µm samples (2 per pixel, regions on pixel boundaries, so each
    pixel's active square sees one temperature): 450 K background, a 900 K spot (valid only at
    20 µs), a 2500 K spot (saturated at every time), a 220 K patch (near the detection limit;
    205 K before issue 20 raised the floor from SNR = 1 to blank + 3σ)."""
    frame = np.full((240, 320), 450.0)
    frame[40:80, 40:100] = 900.0
    frame[160:200, 200:260] = 2500.0
    frame[100:140, 140:180] = 220.0
    return FrameStack(np.repeat(frame[None], n_frames, axis=0), dt=1e-3, dx=3e-6)


def _own_choice(subframes, times):
    valid = np.stack([~(m.saturated | m.under_range | m.over_range) for m in subframes])
    saturated = np.stack([m.saturated for m in subframes])
    order = sorted(range(len(times)), key=lambda j: times[j])
    chosen = np.full(valid.shape[1:], -1)
    for j in order:  # longest valid wins
        chosen[valid[j]] = j
    none = chosen < 0
    chosen[none & saturated.any(axis=0)] = order[0]
    chosen[none & ~saturated.any(axis=0)] = order[-1]
    return chosen, valid.any(axis=0)


FIELDS = ("apparent_temperature", "counts", "electrons", "saturated", "under_range",
          "over_range", "tensor_max", "tensor_mean", "tensor_std", "signal_mean")


@ignore_saturation
@pytest.mark.parametrize("timing", ["frame rate", "itr readout"])
def test_superframe_merges_the_longest_valid_subframe(timing):
    if timing == "frame rate":  # nist-ir at 600 Hz: every subframe one 1/600 s after the last
        camera = nist()
        periods = lambda t: 1 / 600  # noqa: E731
    else:  # no frame rate: integrate then read 120 rows × 10 µs + 100 µs
        camera = camera_with(fpa=dict(readout="itr", row_time=10e-6, readout_overhead=100e-6),
                             frame_rate=None)
        periods = lambda t: t + 120 * 10e-6 + 100e-6  # noqa: E731
    scene = _hot_spot_scene()
    times = [80e-6, 20e-6, 1280e-6, 320e-6]  # not sorted: the camera cycles them in this order
    starts = np.concatenate([[0.0], np.cumsum([periods(t) for t in times[:-1]])])
    rng = np.random.default_rng(31)
    subframes = [camera.measure(scene, t, s, rng) for t, s in zip(times, starts)]
    merged = superframe(camera, scene, times, t_start=0.0, rng=np.random.default_rng(31))

    np.testing.assert_allclose(merged.subframe_starts, starts, rtol=1e-12, atol=0)
    assert merged.subframe_times == tuple(times) and merged.integration_time == max(times)
    chosen, any_valid = _own_choice(subframes, times)
    np.testing.assert_array_equal(merged.subframe, chosen)
    # Static scene: the merged frame is each pixel's chosen subframe, bit for bit.
    for name in FIELDS:
        stack = np.stack([getattr(m, name) for m in subframes])
        expected = np.take_along_axis(stack, chosen[None], 0)[0]
        np.testing.assert_array_equal(getattr(merged, name), expected, err_msg=name)
    # No pixel with a valid subframe is reported saturated (or flagged at all).
    assert not (merged.saturated & any_valid).any()
    np.testing.assert_array_equal(merged.valid, any_valid)
    # The regions: background from 1280 µs, the 900 K spot from 20 µs, the 2500 K spot
    # saturated (from the shortest subframe), the cold patch from the longest if anywhere.
    assert (merged.subframe[:20, :20] == 2).all() and merged.valid[:20, :20].all()
    spot = (slice(21, 39), slice(21, 49))
    assert (merged.subframe[spot] == 1).all() and merged.valid[spot].all()
    np.testing.assert_allclose(merged.apparent_temperature[spot], 900.0, atol=5.0)
    blaze = (slice(81, 99), slice(101, 129))
    assert merged.saturated[blaze].all() and (merged.subframe[blaze] == 1).all()
    # The cold patch, just above the 1280 µs detection limit (208.4 K; it was 193.8 K at
    # SNR = 1): read at 1280 µs wherever that subframe is valid (most pixels); where it is not,
    # a shorter subframe that noise lifted over its own limit is taken.
    cold = (slice(51, 69), slice(71, 89))
    longest_valid = subframes[2].valid[cold]
    assert longest_valid.mean() > 0.5
    assert (merged.subframe[cold][longest_valid] == 2).all()


@ignore_saturation
def test_superframe_of_a_uniform_blackbody_takes_the_longest_unsaturated_time():
    camera = nist()
    scene = UniformBlackbody(600.0, shape=(240, 320), dx=3e-6, dt=1e-3)
    times = [20e-6, 80e-6, 320e-6, 1280e-6]  # 600 K saturates at 1280 µs (from ≈ 494 K)
    rng = np.random.default_rng(5)
    subframes = [camera.measure(scene, t, i / 600, rng) for i, t in enumerate(times)]
    merged = superframe(camera, scene, times, t_start=0.0, rng=5)
    assert subframes[3].saturated.all() and subframes[2].valid.all()
    assert (merged.subframe == 2).all()
    np.testing.assert_array_equal(merged.apparent_temperature, subframes[2].apparent_temperature)
    np.testing.assert_array_equal(merged.counts, subframes[2].counts)


# -- 6. timing ------------------------------------------------------------------------------------


def test_frame_period_is_integration_and_readout():
    row, pixel, overhead = 2e-6, 0.01e-6, 50e-6
    readout = 120 * row + 120 * 160 * pixel + overhead  # 240 + 192 + 50 = 482 µs
    for mode in ("itr", "iwr"):
        camera = camera_with(fpa=dict(readout=mode, row_time=row, pixel_time=pixel,
                                      readout_overhead=overhead), frame_rate=None)
        assert camera.fpa.readout_time((120, 160)) == pytest.approx(readout, rel=1e-12)
        for t in (100e-6, 482e-6, 900e-6):
            own = t + readout if mode == "itr" else max(t, readout)
            assert frame_period(camera, t) == pytest.approx(own, rel=1e-12)
        # A slower frame rate sets the period.
        slow = camera.replace(frame_rate=600.0)
        assert frame_period(slow, 100e-6) == pytest.approx(max(1 / 600, 100e-6 + readout)
                                                          if mode == "itr" else 1 / 600,
                                                          rel=1e-12)
    fpa = FocalPlaneArray(6e-6, row_time=10e-6, readout_overhead=100e-6)  # no shape given
    assert fpa.frame_period(50e-6, (120, 160)) == pytest.approx(1350e-6, rel=1e-12)


def test_record_spaces_windows_by_the_real_frame_period():
    camera = camera_with(fpa=dict(readout="itr", row_time=10e-6, readout_overhead=100e-6),
                         frame_rate=None)
    t_int = 200e-6
    period = t_int + 120 * 10e-6 + 100e-6  # 1.5 ms
    scene = UniformBlackbody(500.0, shape=(240, 320), dx=3e-6, dt=1e-4)
    frames = record(camera, scene, t_int, 4, t_start=0.0, rng=np.random.default_rng(2))
    np.testing.assert_allclose([m.t_start for m in frames], period * np.arange(4), rtol=1e-12,
                               atol=1e-18)
    rng = np.random.default_rng(2)  # the same frames measured one by one
    for i, m in enumerate(frames):
        again = camera.measure(scene, t_int, i * period, rng)
        np.testing.assert_array_equal(m.counts, again.counts)
    # iwr: the readout (1.3 ms) hides the integration.
    iwr = camera_with(base=camera, fpa=dict(readout="iwr"))
    starts = [m.t_start for m in record(iwr, scene, t_int, 3, t_start=0.0, rng=0)]
    np.testing.assert_allclose(starts, 1.3e-3 * np.arange(3), rtol=1e-12, atol=1e-18)


def test_integration_whose_readout_exceeds_the_frame_period_is_refused():
    # 600 Hz: 1666.7 µs per frame; itr with 120 × 10 µs + 100 µs = 1300 µs of readout leaves
    # 366.7 µs of integration.
    camera = camera_with(fpa=dict(readout="itr", row_time=10e-6, readout_overhead=100e-6))
    scene = UniformBlackbody(500.0, shape=(240, 320), dx=3e-6, dt=1e-4)
    camera.measure(scene, 360e-6, 0.0, rng=0)  # fits
    with pytest.raises(RadiosimError, match=r"with its readout .*exceeds the frame period"):
        camera.measure(scene, 400e-6, 0.0, rng=0)
    with pytest.raises(RadiosimError, match="exceeds the frame period"):
        superframe(camera, scene, [20e-6, 400e-6], t_start=0.0, rng=0)
    # Integrating while reading, 400 µs fits (the period is the 1300 µs readout).
    camera_with(base=camera, fpa=dict(readout="iwr")).measure(scene, 400e-6, 0.0, rng=0)


def test_a_camera_whose_readout_fills_its_frame_is_refused_when_built(tmp_path):
    # 1000 Hz: 1000 µs per frame. 256 rows × 10 µs + 100 µs = 2660 µs of readout leaves no
    # integration time: refused at construction (from Python and from a camera file), naming
    # the keys, not at the first measurement with a negative limit.
    shape = dict(shape=(256, 320), row_time=10e-6, readout_overhead=100e-6)
    with pytest.raises(RadiosimError, match=r"2660 µs .* frame_rate_hz = 1000 \(1000 µs\)"):
        camera_with(fpa=dict(readout="itr", **shape), frame_rate=1000.0)
    (tmp_path / "c.toml").write_text(
        'name = "c"\nframe_rate_hz = 1000.0\n[fpa]\nshape = [256, 320]\npixel_pitch_um = 3.0\n'
        'row_time_us = 10.0\nreadout_overhead_us = 100.0\n')
    with pytest.raises(RadiosimError, match=r"c\.toml.*row_time_us = 10.*under 1000 µs"):
        Camera.from_toml(tmp_path / "c.toml")
    # The edges: integrate-then-read needs the readout under the period (then a short
    # integration fits); integrate-while-read takes a readout of the whole period.
    edge = dict(shape=(90, 160), row_time=10e-6, readout_overhead=100e-6)  # 1000 µs exactly
    with pytest.raises(RadiosimError, match="under 1000 µs"):
        camera_with(fpa=dict(readout="itr", **edge), frame_rate=1000.0)
    camera_with(fpa=dict(readout="iwr", **edge), frame_rate=1000.0)  # fits
    under = camera_with(fpa=dict(readout="itr", shape=(89, 160), row_time=10e-6,
                                 readout_overhead=100e-6), frame_rate=1000.0)  # 990 µs
    assert frame_period(under, 10e-6) == pytest.approx(1e-3, rel=1e-12)
    camera_with(fpa=dict(readout="itr", **shape), frame_rate=None)  # no frame rate: any


# -- 7. every new effect off: the old chain bit for bit -----------------------------------------


@ignore_saturation
def test_effects_off_give_the_plain_camera_bit_for_bit():
    plain = nist()
    off = camera_with(fpa=dict(prnu=0.0, dsnu=0.0, nonlinearity_spread=0.0, dead_fraction=0.0,
                               hot_fraction=0.0, pattern_seed=123, pattern_file=None,
                               readout="iwr", row_time=0.0, pixel_time=0.0,
                               readout_overhead=0.0, shutter="snapshot"),
                      electronics=dict(nonlinearity=0.0))
    assert off.fpa.pattern((120, 160)) is None and plain.fpa.pattern((120, 160)) is None
    scenes = [_hot_spot_scene(), UniformBlackbody(550.0, shape=(240, 320), dx=3e-6, dt=1e-4)]
    for scene in scenes:
        a = plain.measure(scene, 320e-6, 0.0, rng=np.random.default_rng(99))
        b = off.measure(scene, 320e-6, 0.0, rng=np.random.default_rng(99))
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        # The EMVA 1288 linear chain written out, with the same generator: Poisson charge of
        # the mean (photo + dark), full-well clip, Gaussian read noise, rounding and clipping.
        el = plain.electronics
        rng = np.random.default_rng(99)
        photo = a.signal_mean * plain.etendue * 320e-6
        charge = rng.poisson(np.clip(photo + el.dark_current * 320e-6, 0, None)).astype(float)
        charge = np.minimum(charge, el.full_well)
        read = charge + rng.normal(0.0, el.read_noise, charge.shape)
        counts = np.clip(np.rint(el.gain * read + el.offset), 0, 2**el.adc_bits - 1)
        np.testing.assert_array_equal(a.electrons, charge)
        np.testing.assert_array_equal(a.counts, counts)


# -- 8. the fixed pattern --------------------------------------------------------------------------


def test_pattern_is_seeded_and_cropped():
    fpa = dataclasses.replace(nist().fpa, prnu=0.02, dsnu=1000.0, nonlinearity_spread=0.1,
                              dead_fraction=0.01, hot_fraction=0.01, pattern_seed=4)
    maps = ("gain", "dark", "nonlinearity", "dead", "hot")
    a, b = fpa.pattern((120, 160)), fpa.pattern((120, 160))
    for name in maps:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    other = dataclasses.replace(fpa, pattern_seed=5).pattern((120, 160))
    for name in ("gain", "dark", "nonlinearity"):
        assert not np.array_equal(getattr(a, name), getattr(other, name))
    small = fpa.pattern((50, 70))
    for name in maps:
        np.testing.assert_array_equal(getattr(small, name), getattr(a, name)[:50, :70])
    with pytest.raises(RadiosimError, match="measured on a"):
        fpa.pattern((121, 160))
    # Dead and hot pixels are disjoint, each ≈ 1 % (binomial: 4√(p(1 − p)/N) = 0.29 %).
    assert not (a.dead & a.hot).any()
    n = a.dead.size
    for mask in (a.dead, a.hot):
        assert mask.mean() == pytest.approx(0.01, abs=K_SIGMA * math.sqrt(0.01 * 0.99 / n))


def test_pattern_file_is_used(tmp_path):
    rng = np.random.default_rng(17)
    shape = (130, 170)  # larger than the array: cropped
    prnu = 0.03 * rng.standard_normal(shape)
    dsnu = 2000.0 * rng.standard_normal(shape)
    nonlinearity = 1 + 0.2 * rng.standard_normal(shape)
    dead = np.zeros(shape, bool)
    hot = np.zeros(shape, bool)
    dead[3, 5] = dead[60, 100] = True
    hot[10, 20] = hot[119, 159] = True
    path = tmp_path / "pattern.npz"
    np.savez(path, prnu=prnu, dsnu_e=dsnu, nonlinearity=nonlinearity, dead=dead, hot=hot)
    beta = 0.05
    camera = quiet(camera_with(fpa=dict(pattern_file=str(path)),
                               electronics=dict(nonlinearity=beta)))
    pattern = camera.fpa.pattern((120, 160))
    np.testing.assert_array_equal(pattern.gain, 1 + prnu[:120, :160])
    np.testing.assert_array_equal(pattern.dark, dsnu[:120, :160])
    el = camera.electronics
    flat, saturated = flat_field(camera, 550.0, T_INT, frames=1, rng=0)
    x = camera.calibration(T_INT).photoelectrons(550.0)  # the forward model's photo-charge
    e = np.where(dead[:120, :160], 0.0, x * (1 + prnu[:120, :160])) + el.dark_current * T_INT \
        + dsnu[:120, :160]
    e = np.where(hot[:120, :160], el.full_well, e)
    b = beta * nonlinearity[:120, :160]
    expected = el.offset + el.gain * e * (1 - b * e / el.full_well)
    np.testing.assert_allclose(flat, expected, rtol=1e-12)
    np.testing.assert_array_equal(saturated, hot[:120, :160])


@ignore_saturation
def test_dead_pixels_read_dark_hot_pixels_saturate_and_the_nuc_replaces_them():
    camera = camera_with(fpa=dict(prnu=0.01, dsnu=3000.0, dead_fraction=0.01,
                                  hot_fraction=0.01, pattern_seed=6))
    el = camera.electronics
    pattern = camera.fpa.pattern((120, 160))
    scene = UniformBlackbody(550.0, shape=(240, 320), dx=3e-6, dt=1e-4)
    m = camera.measure(scene, T_INT, 0.0, rng=np.random.default_rng(40))
    # Dead: the dark level of the pixel, offset + K(D + d_ij), within 6 σ_dark (σ ≈ 0.9 DN;
    # 6σ: no dead pixel of ≈ 200 should stray, P ≈ 2e-9 each) — the lit level is ≈ 4700 DN up.
    dark_level = el.offset + el.gain * (el.dark_current * T_INT + pattern.dark)
    sigma_dark = math.sqrt(el.gain**2 * (el.read_noise**2 + el.dark_current * T_INT) + 1 / 12)
    assert pattern.dead.sum() > 100
    np.testing.assert_allclose(m.counts[pattern.dead], dark_level[pattern.dead],
                               atol=6 * sigma_dark)
    # Their reading is a dark one: the calibration reports at most the temperature whose
    # photo-charge equals the largest DSNU offset (|z| < 5 over ≈ 200 pixels) plus 6 σ_dark
    # (a positive offset reads as a little light; the NUC, below, finds them).
    from scipy.optimize import brentq

    charge = 5 * 3000.0 + 6 * sigma_dark / el.gain  # [e⁻]
    ceiling = brentq(lambda t: own_band().photoelectrons(t, T_INT) - charge, 150.0, 500.0)
    assert np.nan_to_num(m.apparent_temperature[pattern.dead], nan=0.0).max() < ceiling < 300
    # Hot: a stuck full well, flagged saturated, at the converter's top (within read noise).
    assert m.saturated[pattern.hot].all() and np.isnan(m.apparent_temperature[pattern.hot]).all()
    assert (m.counts[pattern.hot] >= el.offset + el.gain * el.full_well - 6 * sigma_dark).all()
    lit = ~(pattern.dead | pattern.hot)
    assert m.valid[lit].all()

    corrected_camera = fit_nuc(camera, [500.0, 600.0], T_INT, frames=8, rng=41)
    nuc = corrected_camera.nuc
    assert nuc.bad[pattern.dead | pattern.hot].all()
    assert nuc.bad.sum() == (pattern.dead | pattern.hot).sum()  # and no lit pixel
    m_nuc = corrected_camera.measure(scene, T_INT, 0.0, rng=np.random.default_rng(40))
    np.testing.assert_array_equal(m_nuc.electrons, m.electrons)  # the same read-out
    # Our two-point map of the raw counts, then each bad pixel the median of the good ones of
    # its 3 × 3 neighbourhood (wider only if none is good).
    (p1, p2), (t1, t2) = nuc.points, nuc.targets
    with np.errstate(divide="ignore", invalid="ignore"):  # dead and hot: p₂ = p₁
        mapped = t1 + (m.counts - p1) * (t2 - t1) / (p2 - p1)
    expected = mapped.copy()
    bad = nuc.bad
    for i, j in zip(*np.nonzero(bad)):
        reach = 1
        while True:
            block = (slice(max(i - reach, 0), i + reach + 1),
                     slice(max(j - reach, 0), j + reach + 1))
            near = mapped[block][~bad[block]]
            if near.size:
                expected[i, j] = np.median(near)
                break
            reach += 1
    np.testing.assert_allclose(m_nuc.counts, expected, rtol=1e-12)
    # After the NUC every pixel reads the blackbody (bad ones through their neighbours).
    assert m_nuc.valid.all()
    np.testing.assert_allclose(m_nuc.apparent_temperature, 550.0, atol=1.0)


def test_replace_bad_pixels_by_hand():
    values = np.arange(25.0).reshape(5, 5)
    bad = np.zeros((5, 5), bool)
    bad[0, 0] = True  # neighbours 1, 5, 6 → 5
    assert replace_bad_pixels(values, bad)[0, 0] == 5.0
    bad = np.zeros((5, 5), bool)
    bad[1:4, 1:4] = True
    out = replace_bad_pixels(values, bad)
    assert out[1, 1] == 2.0  # good neighbours 0, 1, 2, 5, 10 → 2
    assert out[2, 1] == 10.0  # good neighbours 5, 10, 15 → 10
    # The centre has no good 3 × 3 neighbour: the 16 good pixels of its 5 × 5 block,
    # 0–4, 5, 9, 10, 14, 15, 19, 20–24, have the median (10 + 14)/2 = 12.
    assert out[2, 2] == 12.0
    np.testing.assert_array_equal(out[~bad], values[~bad])
    with pytest.raises(RadiosimError, match="every pixel is bad"):
        replace_bad_pixels(values, np.ones((5, 5), bool))


# -- 9. the datasheet command and bad inputs ------------------------------------------------------


def test_report_writes_the_datasheet(tmp_path, capsys):
    from radiosim.cli import main

    out = tmp_path / "report"
    assert main(["report", "nist-ir", "--out", str(out)]) == 0
    assert sorted(p.name for p in out.glob("*.png")) == ["netd.png", "photon_transfer.png",
                                                         "range.png"]
    from matplotlib.image import imread

    from radiosim.plotting import DPI

    for png in out.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        # It decodes whole, at the datasheet's figure size (6 × 4 in), and holds data: the axes
        # and text are black on white, the curves coloured (≈ 1 % of the pixels in each
        # figure; a figure without its curves has none): at least 0.2 % asserted.
        rgb = imread(png)[..., :3]
        assert rgb.shape == (round(4 * DPI), round(6 * DPI), 3), png.name
        assert np.all(rgb[0] == 1.0) and np.mean(rgb < 0.9) > 0.01, png.name  # white, drawn
        coloured = rgb.max(axis=-1) - rgb.min(axis=-1) > 0.2
        assert coloured.mean() > 2e-3, png.name
    with open(out / "datasheet.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    quantities = {r["quantity"] for r in rows}
    assert {"system gain K", "dark noise", "saturation capacity", "DSNU", "PRNU",
            "linearity error", "NETD", "lowest measurable temperature",
            "saturation temperature"} <= quantities
    value = {r["quantity"]: float(r["value"]) for r in rows}
    camera, el = nist(), nist().electronics
    # The PTC's variances come from 64 × 64-pixel pairs: relative SE √(2/4096) = 2.2 % each;
    # the gain fit averages several levels, so 4 × 2.2 % bounds it.
    assert value["system gain K"] == pytest.approx(el.gain, rel=K_SIGMA * math.sqrt(2 / 4096))
    assert value["dark noise"] == pytest.approx(math.hypot(el.read_noise, math.sqrt(
        el.dark_current * T_INT)), rel=K_SIGMA * 1.5 * math.sqrt(2 / 4096))  # √var_d / K̂:
    # half the dark variance's relative error plus the gain's
    assert 0.85 * el.full_well < value["saturation capacity"] < el.full_well
    # nist-ir has no fixed pattern: DSNU and PRNU are only the estimators' noise. The spatial
    # variance less σ²_t/L has SE ≈ (σ²_t/L)√(2/N + 2/(N(L − 1))) with N = 19200, L = 16: 4 SE
    # is 2.1e-3 DN² in the dark (σ_t = 0.89 DN) → DSNU ≤ 0.046 DN / K = 33 e⁻, and
    # 3.0e-2 DN² at ≈ 580 K (σ_t ≈ 3.4 DN) → PRNU ≤ 0.17 DN / 6700 DN = 0.0026 %.
    assert 0 <= value["DSNU"] < 33.0 and 0 <= value["PRNU"] < 0.0026
    assert 0 <= value["linearity error"] < 0.05  # linear up to the clip: noise only
    # The NETD rows are the camera's own at the temperatures the command chose (12 from the
    # noise floor up to saturation) and the range rows its measurable range at 13 times from
    # 1 µs to one frame: equal to the CSV's 6 significant digits.
    calibration = camera.calibration(T_INT)
    netd_temperatures = np.linspace(calibration.lowest_measurable_temperature(),
                                    calibration.saturation_temperature, 12, endpoint=False)
    netd_rows = [float(r["value"]) for r in rows if r["quantity"] == "NETD"]
    np.testing.assert_allclose(netd_rows, netd(camera, netd_temperatures, T_INT), rtol=5e-6)
    times = np.geomspace(1e-6, 1 / camera.frame_rate, 13)
    limits = np.array([measurable_range(camera, t) for t in times])
    for column, quantity in enumerate(("lowest measurable temperature",
                                       "saturation temperature")):
        got = [float(r["value"]) for r in rows if r["quantity"] == quantity]
        np.testing.assert_allclose(got, limits[:, column], rtol=5e-6)
    # An existing, non-empty folder is refused without --overwrite (exit code 2).
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "notes.txt").write_text("mine")
    capsys.readouterr()
    assert main(["report", "nist-ir", "--out", str(taken)]) == 2
    assert "not empty" in capsys.readouterr().err
    assert (taken / "notes.txt").read_text() == "mine" and not (taken / "datasheet.csv").exists()


def test_report_of_a_camera_file_with_a_bad_field(tmp_path, capsys):
    from radiosim.cli import main

    text = (Path(radiosim.__file__).parent / "presets" / "nist-ir.toml").read_text()
    path = tmp_path / "bad.toml"
    path.write_text(text.replace("[fpa]\n", "[fpa]\nprnu = -0.01\n"))
    assert main(["report", str(path), "--out", str(tmp_path / "out")]) == 2
    assert "prnu must be ≥ 0" in capsys.readouterr().err


def test_bad_inputs_are_refused_clearly():
    fpa = nist().fpa
    with pytest.raises(RadiosimError, match=r"prnu must be ≥ 0, got -0\.01"):
        dataclasses.replace(fpa, prnu=-0.01)
    with pytest.raises(RadiosimError, match=r"dsnu must be ≥ 0"):
        dataclasses.replace(fpa, dsnu=float("nan"))
    with pytest.raises(RadiosimError, match=r"dead_fraction and hot_fraction .* sum ≤ 1"):
        dataclasses.replace(fpa, dead_fraction=0.6, hot_fraction=0.5)
    with pytest.raises(RadiosimError, match=r"readout must be 'itr' .* or 'iwr' .*'xyz'"):
        dataclasses.replace(fpa, readout="xyz")
    with pytest.raises(RadiosimError, match=r"row_time must be ≥ 0"):
        dataclasses.replace(fpa, row_time=-1e-6)
    with pytest.raises(RadiosimError, match=r"nonlinearity must be in \[0, 0\.5\).*0\.7"):
        Electronics(full_well=1e6, nonlinearity=0.7)
    with pytest.raises(RadiosimError, match="give full_well"):
        Electronics(nonlinearity=0.05)
    flats = np.stack([np.full((4, 4), 2000.0), np.full((4, 4), 1000.0)])
    with pytest.raises(RadiosimError, match=r"NUC temperatures must increase"):
        NonUniformityCorrection.from_flat_fields(flats, [600.0, 500.0], T_INT)
    with pytest.raises(RadiosimError, match=r"NUC temperatures must increase"):
        fit_nuc(nist(), [600.0, 500.0], T_INT, frames=2, rng=0)
    with pytest.raises(RadiosimError, match="pattern file .* cannot read|cannot read the pattern"):
        dataclasses.replace(fpa, pattern_file="/nonexistent/pattern.npz").pattern((120, 160))

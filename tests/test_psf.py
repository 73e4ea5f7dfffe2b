"""
The optics' point-spread function (radiosim.psf and the image stage of radiosim.imaging),
checked against references computed here, independently of the FFT blur:

-   energy conservation on a uniform infinite scene;
-   the Airy ensquared energy of a point-like source (2-D quadrature of (2 J1(v)/v)²);
-   the edge response as the 1-D Fourier integral of the circular-pupil MTF × the pixel sinc;
-   blurring the window mean equals blurring every frame;
-   polychromatic diffraction: the sub-bands add up, and the count that keeps 0.1 K;
-   the scatter halo's size-of-source effect on a disc;
-   bad PSF inputs and the camera-file round trip of [[optics.psf]] tables.
"""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.constants as sc
from scipy import integrate, optimize, special

import radiosim as rs
from radiosim.errors import RadiosimError
from radiosim.imaging import sample_signals, sub_band_count
from radiosim.integrator import Window
from radiosim.psf import (PAD_ENERGY, Diffraction, GaussianBlur, ScatterHalo, TabulatedPSF,
                          airy_encircled_energy, as_psf, blur, halo_encircled_energy)
from radiosim.scenes import StepEdge, UniformBlackbody

LAMBDA = 4.5e-6  # [m] the monochromatic tests' wavelength
NARROW_BAND = (4.49e-6, 4.51e-6)  # its band: the linear response blurs at the band's centre


def with_psf(camera, psf, **optics):
    """The camera with these PSFs (and other optics changes)."""
    return camera.replace(optics=dataclasses.replace(camera.optics, psf=psf, **optics))


def linear_camera(pitch, psf=None, **optics):
    """The paper's ideal linear camera (signal = T, so the PSF blurs T linearly)."""
    return with_psf(rs.Camera.linear_ideal(pitch), psf, **optics)


def nist_camera(psf=None, **optics):
    """nist-ir with ideal electronics and as many pixels as the scene holds."""
    camera = rs.Camera.preset("nist-ir")
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, shape=None),
                            electronics=rs.Electronics.ideal())
    return with_psf(camera, psf, **optics)


def one_frame(camera, scene):
    """The image [signal unit] of the scene's first frame (a one-frame window)."""
    return camera.image(scene, Window(0.0, scene.dt))


def airy_psf(na, wavelength):
    """The Airy intensity h(r) [m⁻²], normalised to unit integral (Born & Wolf §8.5.2):
    h = (π NA²/λ²) (2 J1(v)/v)², v = 2π NA r/λ."""
    k = 2 * math.pi * na / wavelength
    peak = math.pi * na**2 / wavelength**2

    def h(r):
        v = k * r
        return peak if v < 1e-8 else peak * (2 * special.j1(v) / v) ** 2

    return h, k, peak


def circular_mtf(f, cutoff):
    """The diffraction-limited MTF of a circular pupil (Goodman §6.3.2)."""
    nu = f / cutoff
    if nu >= 1:
        return 0.0
    return (2 / math.pi) * (math.acos(nu) - nu * math.sqrt(1 - nu * nu))


# -- 1. energy conservation ----------------------------------------------------------------


def _tabulated():
    rng = np.random.default_rng(11)
    return TabulatedPSF(rng.random((7, 5)), 1.3e-6)  # asymmetric, odd pitch


PSF_CASES = {
    "diffraction": Diffraction(3),
    "gaussian": GaussianBlur(2e-6),
    "halo": ScatterHalo(0.1, 20e-6),
    "tabulated": _tabulated(),
    "list": (Diffraction(2), GaussianBlur(1e-6), ScatterHalo(0.05, 10e-6), _tabulated()),
}


@pytest.mark.parametrize("response", ["linear", "planck"])
@pytest.mark.parametrize("name", list(PSF_CASES))
def test_a_psf_changes_no_pixel_of_a_uniform_infinite_scene(name, response):
    # A uniform scene whose surroundings are at its own temperature is a uniform infinite
    # field; every PSF has unit integral (OTF 1 at f = 0), so each pixel keeps the sample
    # signal. The only error is rounding in the FFT and sums: 1e-12 relative.
    psf = PSF_CASES[name]
    t = 700.0
    scene = UniformBlackbody(t, shape=(24, 30), dx=1e-6, dt=1e-6, emissivity=0.8)
    if response == "linear":
        scene.set_environment(surroundings_temperature=t)
        camera = linear_camera(3e-6, psf)
        expected = t
    else:
        # ε = 0.8 reflecting (1 − ε) of a surround at T: ε L(T) + (1 − ε) L(T) = L(T), the
        # surroundings' own radiance; summed sub-band by sub-band as the image stage splits it.
        scene.set_environment(reflected_temperature=t, surroundings_temperature=t)
        camera = nist_camera(psf)
        n = sub_band_count(camera.optics.psf)
        expected = sum(float(sub.grey_signal(t))
                       for sub, _ in camera.response_model.sub_bands(n))
    image = one_frame(camera, scene)
    assert image.shape == ((8, 10) if response == "linear" else (4, 5))
    np.testing.assert_allclose(image, expected, rtol=1e-12, atol=0)


def test_a_psf_keeps_the_apparent_temperature_of_a_uniform_infinite_blackbody():
    # Through the whole chain: the sub-bands sum to the full band within the radiance table's
    # 1e-7, so the apparent temperature is exact to 1e-7 L / (dL/dT) ≈ 1e-7 · λT²/c2 ≈ 2e-5 K
    # at 800 K (c2 = 14388 µm K, λ ≈ 4.5 µm); 1e-4 K asserted.
    t = 800.0
    scene = UniformBlackbody(t, shape=(18, 18), dx=1e-6, dt=1e-6)
    scene.set_environment(surroundings_temperature=t)
    camera = nist_camera((Diffraction(8), ScatterHalo(0.02, 50e-6)))
    m = camera.measure(scene, 1e-6)
    np.testing.assert_allclose(m.apparent_temperature, t, atol=1e-4, rtol=0)


# -- 2. diffraction: ensquared energy of a point-like source --------------------------------


def ensquared_energy(h, pitch, x0=0.0):
    """Fraction of the PSF h(r) [m⁻²] of a point at (x0, 0) inside the square pixel
    [−p/2, p/2]², by 2-D adaptive quadrature."""
    half = pitch / 2
    value, _ = integrate.dblquad(lambda y, x: h(math.hypot(x - x0, y)), -half, half,
                                 -half, half, epsabs=1e-12, epsrel=1e-11)
    return value


@pytest.mark.parametrize("v", [0.5, 1.0, 3.8317, 7.0, 20.0])
def test_the_radial_airy_integral_is_one_minus_j0_squared_minus_j1_squared(v):
    # Our reference PSF's normalisation and the closed form 1 − J0² − J1² (Born & Wolf):
    # 2π ∫0^R h(r) r dr by quadrature, to 1e-10.
    na = 0.2
    h, k, _ = airy_psf(na, LAMBDA)
    radius = v / k
    radial, _ = integrate.quad(lambda r: 2 * math.pi * r * h(r), 0, radius, limit=200,
                               epsabs=1e-13, epsrel=1e-12)
    closed = 1 - special.j0(v) ** 2 - special.j1(v) ** 2
    assert radial == pytest.approx(closed, abs=1e-10)
    assert float(airy_encircled_energy(radius, LAMBDA, na)) == pytest.approx(closed, abs=1e-12)


@pytest.mark.parametrize("pitch_samples", [3, 11, 33])
def test_diffraction_ensquared_energy_of_a_point_like_source(pitch_samples):
    # A linear camera (signal = T) at one wavelength with Diffraction: one hot sample of a
    # 1 µm grid, centred in a pixel of p = 3, 11 or 33 µm, on a background equal to the
    # surroundings (so only the hot sample's excess is blurred). The pixel's excess mean,
    # ΔT_pixel = ΔT (dx/p)² E, gives E, the fraction of the source's light in the pixel.
    dx, n = 1e-6, 99
    pitch = pitch_samples * dx
    centre = n // 2
    assert centre % pitch_samples == pitch_samples // 2  # the sample is a pixel's centre
    background, excess = 300.0, 500.0
    stack = np.full((1, n, n), background)
    stack[0, centre, centre] += excess
    scene = rs.FrameStack(stack, dt=1e-6, dx=dx)
    scene.set_environment(surroundings_temperature=background)
    camera = linear_camera(pitch, Diffraction(), band=NARROW_BAND)
    na = camera.optics.object_na(camera.fpa)
    assert na == pytest.approx(1 / math.sqrt(4 * 2.5**2 + 1), rel=1e-14)  # f/2.5, m = 1
    image = one_frame(camera, scene)
    k = centre // pitch_samples
    simulated = (image[k, k] - background) / excess * (pitch / dx) ** 2

    h, wavenumber, peak = airy_psf(na, LAMBDA)
    e0 = ensquared_energy(h, pitch)  # a point source at the pixel's centre
    e1 = ensquared_energy(h, pitch, dx / 2)  # … moved by half the source's width
    # Tolerance from the finite source: the source is a uniform dx square, so the pixel
    # sees E averaged over source positions, E0 + (dx²/24)(Exx + Eyy) + O(dx⁴) = E0 +
    # (dx²/12) Exx by symmetry, while E(dx/2, 0) = E0 + (dx²/8) Exx + O(dx⁴): the shift is
    # (2/3)(E1 − E0), and the next order is O((dx/ℓ)²) of it, ℓ ≥ the pixel or the Airy
    # core (≥ 3 dx): ≤ 10 % of |E1 − E0|.
    # Periodic copies of the source (the FFT period is ≥ 2 n dx on each axis) add at most
    # p² h_env(D) each, with the Airy envelope h_env = peak · 8/(π v³).
    period = 2 * n * dx
    wrap = sum(pitch**2 * peak * 8 / (math.pi * (wavenumber * period * math.hypot(i, j)) ** 3)
               for i in range(-30, 31) for j in range(-30, 31) if (i, j) != (0, 0))
    finite_source = e1 - e0
    assert abs(simulated - e0) <= abs(finite_source) + wrap
    assert simulated == pytest.approx(e0 + 2 / 3 * finite_source,
                                      abs=0.1 * abs(finite_source) + wrap + 1e-12)
    # And E0 lies between the closed-form energies of the inscribed and circumscribed
    # circles.
    v_in, v_out = wavenumber * pitch / 2, wavenumber * pitch / math.sqrt(2)
    assert 1 - special.j0(v_in) ** 2 - special.j1(v_in) ** 2 < e0 < \
        1 - special.j0(v_out) ** 2 - special.j1(v_out) ** 2


# -- 3. diffraction: edge response ----------------------------------------------------------


def half_plane_fraction(u, pitch, cutoff):
    """The fraction of a half-plane x' < 0 that a pixel of width p centred at x = u sees
    through a circular pupil: ½ − (1/π) ∫0^fc MTF(f) sinc(f p) sin(2π f u) / f df (a unit
    step is ½ + (1/π) ∫0^∞ sin(2π f x)/f df; the even PSF and the pixel box multiply each
    frequency by MTF · sinc; the MTF vanishes beyond fc)."""
    if u == 0:
        return 0.5
    value, _ = integrate.quad(
        lambda f: circular_mtf(f, cutoff) * np.sinc(f * pitch) * math.sin(2 * math.pi * f * u) / f,
        0, cutoff, limit=400, epsabs=1e-12, epsrel=1e-11)
    return 0.5 - value / math.pi


@pytest.mark.parametrize("case", ["f/2.5, m = 1", "objective NA 0.1, m = 5"])
def test_diffraction_edge_response_is_mtf_times_pixel_sinc(case):
    # A StepEdge (hot left, cold right) on a sample and pixel boundary, through a linear
    # camera at one wavelength with monochromatic diffraction (MTF cut-off 2 NA/λ in object
    # space). Pixel readings in a middle row are compared with the 1-D Fourier integral of
    # half_plane_fraction, done by scipy quad, not FFT.
    pitch, dx = 6e-6, 3e-6
    width, height = 1200e-6, 2400e-6
    edge = width / 2
    hot, cold = 1000.0, 400.0
    mid = 0.5 * (hot + cold)
    camera = linear_camera(pitch, Diffraction(1), band=NARROW_BAND)
    na = 1 / math.sqrt(26)  # the f/2.5 cold stop, object side at m = 1
    if case.startswith("objective"):
        camera = camera.replace(fpa=dataclasses.replace(camera.fpa, detector_pitch=5 * pitch))
        camera = with_psf(camera, Diffraction(1), band=NARROW_BAND, objective_na=0.1)
        na = 0.1  # the objective's image-side cone NA/m = 0.02 is narrower than f/2.5
    assert camera.optics.object_na(camera.fpa) == pytest.approx(na, rel=1e-13)
    cutoff = 2 * na / LAMBDA
    scene = StepEdge(hot, cold, edge=edge, shape=(round(height / dx), round(width / dx)),
                     dx=dx, dt=1e-6)
    # Surroundings at the mean temperature: the light the finite scene lacks beyond its
    # edges is then odd about the edge line and cancels to first order for pixels near it.
    scene.set_environment(surroundings_temperature=mid)
    image = one_frame(camera, scene)
    row = image[image.shape[0] // 2]
    centres = (np.arange(row.size) + 0.5) * pitch
    near = np.flatnonzero(np.abs(centres - edge) < 40e-6)
    assert near.size == 14
    for j in near:
        x = centres[j]
        # The scene's finite width is exact in 1-D: hot on [0, e], cold on [e, W], the
        # surroundings beyond (superposed half-planes).
        expected = (mid + (hot - mid) * (half_plane_fraction(x - edge, pitch, cutoff)
                                         - half_plane_fraction(x, pitch, cutoff))
                    + (cold - mid) * (half_plane_fraction(x - width, pitch, cutoff)
                                      - half_plane_fraction(x - edge, pitch, cutoff)))
        # Tolerance from the scene's finite height Y = H/2 each way: beyond it the true step
        # (±ΔT/2 about the surroundings) is missing; integrated over x' this is the odd
        # moment of the PSF over |x' − x| < |u| (u = x − e), ≈ 2|u| h(0, y). With the Airy
        # envelope h ≤ (πNA²/λ²) 8/(π v³), ∫_Y^∞ h dy = λ/(2π³ NA Y²), so on both sides
        # |error| ≤ ΔT |u| λ / (π³ NA Y²); doubled for the periodic copies of the padded
        # FFT grid, whose odd parts also cancel to first order in u.
        u = abs(x - edge)
        tolerance = 2 * (hot - cold) * u * LAMBDA / (math.pi**3 * na * (height / 2) ** 2)
        assert row[j] == pytest.approx(expected, abs=tolerance + 1e-9 * hot), (case, x - edge)
    # The edge blurs: the pixels beside it are well inside (cold, hot), symmetric about mid.
    left, right = near[6], near[7]
    assert row[left] + row[right] == pytest.approx(2 * mid, abs=1e-6)
    assert cold + 0.1 * (hot - cold) < row[right] < mid


# -- 4. blurring the window mean once = blurring every frame ---------------------------------


@pytest.mark.parametrize("response", ["linear", "planck"])
def test_blurring_the_window_mean_equals_blurring_every_frame(response):
    # The PSF and the time average are both linear in radiance: the image of a window equals
    # the time-weighted mean of the images of its frames, each blurred on its own. A moving
    # scene (five different frames), a window starting and ending mid-frame, and per-frame
    # reflected temperatures (the planck case: ε = 0.8). Rounding only: 1e-12 relative.
    rng = np.random.default_rng(4)
    n_frames, dt = 5, 1e-6
    stack = 400.0 + 500.0 * rng.random((n_frames, 18, 24))
    reflected = np.array([300.0, 350.0, 400.0, 450.0, 500.0])
    psf = (Diffraction(3), ScatterHalo(0.05, 10e-6), GaussianBlur(1e-6))
    camera = linear_camera(3e-6, psf) if response == "linear" else nist_camera(psf)
    emissivity = 1.0 if response == "linear" else 0.8

    def stack_scene(frames, reflected_temperature):
        scene = rs.FrameStack(frames, dt=dt, dx=1e-6, emissivity=emissivity)
        return scene.set_environment(reflected_temperature=reflected_temperature,
                                     surroundings_temperature=350.0)

    scene = stack_scene(stack, reflected)
    start, duration = 0.3 * dt, 3.4 * dt  # frames 0–3, weights 0.7, 1, 1, 0.7 (÷ 3.4)
    window_image = camera.image(scene, Window(start, duration))
    weights = np.array([0.7, 1.0, 1.0, 0.7]) / 3.4
    mean_of_frames = sum(w * one_frame(camera, stack_scene(stack[k:k + 1], reflected[k]))
                         for k, w in enumerate(weights))
    np.testing.assert_allclose(window_image, mean_of_frames, rtol=1e-12, atol=0)
    # and the frames differ enough for this to mean something
    first = one_frame(camera, stack_scene(stack[:1], reflected[0]))
    assert np.max(np.abs(first - window_image) / window_image) > 1e-3


# -- 5. polychromatic diffraction -----------------------------------------------------------


@pytest.mark.parametrize("n", [2, 5, 8, 32])
def test_sub_band_signals_sum_to_the_full_band(n):
    # Equal-width sub-bands partition the band: their in-band radiances add up to the full
    # band's within the radiance tables' precision (1e-7 each; 1e-6 asserted).
    response = rs.Camera.preset("nist-ir").response_model
    bands = response.sub_bands(n)
    assert len(bands) == n
    edges = [sub.band for sub, _ in bands]
    assert edges[0][0] == response.band[0] and edges[-1][1] == pytest.approx(response.band[1])
    assert all(a[1] == pytest.approx(b[0], rel=1e-15) for a, b in zip(edges, edges[1:]))
    for (lo, hi), (_, wavelength) in zip(edges, bands):
        assert wavelength == pytest.approx(0.5 * (lo + hi), rel=1e-15)
    t = np.array([150.0, 300.0, 800.0, 2000.0, 3000.0])
    total = sum(sub.grey_signal(t) for sub, _ in bands)
    np.testing.assert_allclose(total, response.grey_signal(t), rtol=1e-6)


def test_sub_band_sample_signals_sum_to_the_full_band_with_reflection():
    # The image stage's per-sample window means, sub-band by sub-band, of a scene that emits
    # (ε = 0.6) and reflects (1 − ε) a hotter surround: they add up to the full band's
    # (table precision, 1e-6).
    rng = np.random.default_rng(5)
    stack = 300.0 + 900.0 * rng.random((2, 6, 8))
    scene = rs.FrameStack(stack, dt=1e-6, dx=1e-6, emissivity=0.6)
    scene.set_environment(reflected_temperature=450.0)
    response = nist_camera().response_model
    window = Window(0.25e-6, 1.5e-6)
    full = sample_signals(scene, window, [response])[0]
    subs = sample_signals(scene, window, [sub for sub, _ in response.sub_bands(6)])
    np.testing.assert_allclose(subs.sum(axis=0), full, rtol=1e-6)
    # the reflection is in it: 0.4 L(450 K) is not negligible against the emission
    assert np.min(0.4 * response.grey_signal(450.0) / full) > 1e-3


def test_many_sub_bands_work_with_the_preset_band():
    scene = UniformBlackbody(800.0, shape=(12, 12), dx=1e-6, dt=1e-6)
    scene.set_environment(surroundings_temperature=800.0)
    m = nist_camera(Diffraction(64)).measure(scene, 1e-6)
    np.testing.assert_allclose(m.apparent_temperature, 800.0, atol=1e-4)


# The polychromatic reference of the sub-band test below, computed here from closed forms:
# Planck's photon radiance, nist-ir's shipped spectral curves (read from their CSV files), the
# Airy pattern (airy_psf), scipy's adaptive quadrature over the pixel and the spot and
# Gauss–Legendre over wavelength: not radiosim's tables, sub-band responses or FFT.

SPECTRA = Path(__file__).resolve().parents[1] / "spectra"
NIST_CURVES = ("filter_mwir_3.8-5.1um", "optics_mwir_lens", "qe_insb_77K")
FILTER_BAND = (3.78e-6, 5.12e-6)  # [m] the filter's support (0 at both ends)


def shipped_curve(name):
    """A shipped spectral curve as (wavelength [m], value), its CSV file parsed here (comment
    lines, a header, then µm and the value); linear between nodes, 0 outside (as documented)."""
    lines = [line for line in (SPECTRA / f"{name}.csv").read_text().splitlines()
             if line.strip() and not line.startswith("#")]
    data = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    return data[:, 0] * 1e-6, data[:, 1]


def spectral_rule(lo, hi, curves):
    """Nodes [m] and weights [m] × the curves' product for ∫_lo^hi … dλ: 8-point Gauss–Legendre
    on each interval between the curves' nodes, where the product is a polynomial of degree ≤ 3
    and Planck's law smooth: exact to rounding for these 0.01–0.02 µm intervals."""
    x, w = np.polynomial.legendre.leggauss(8)
    edges = np.unique(np.concatenate([c[0] for c in curves] + [[lo, hi]]))
    edges = edges[(edges >= lo) & (edges <= hi)]
    a, b = edges[:-1, None], edges[1:, None]
    nodes = (0.5 * (b - a) * x + 0.5 * (a + b)).ravel()
    weights = (0.5 * (b - a) * w).ravel()
    for c in curves:
        weights = weights * np.interp(nodes, *c, left=0.0, right=0.0)
    return nodes, weights


def photon_radiance(wavelength, temperature):
    """Planck's spectral photon radiance 2c / (λ⁴ (exp(hc/λkT) − 1)) [photons s⁻¹ m⁻² sr⁻¹
    m⁻¹], temperatures along the first axis."""
    t = np.asarray(temperature, dtype=float)[..., None]
    return 2 * sc.c / wavelength**4 / np.expm1(sc.h * sc.c / (wavelength * sc.k * t))


def box_overlap(a0, a1, b0, b1):
    return max(0.0, min(a1, b1) - max(a0, b0))


def rectangle_in_pixel(wavelength, na, pixel, rect):
    """The fraction of a uniform rectangle's excess radiance that a pixel's mean sees through
    the Airy pattern at ``wavelength`` [m] (boxes ((x0, x1), (y0, y1)) in µm): (1/|P|) ∫∫
    h(u, v) |R ∩ (P − (u, v))| du dv, the overlap a product of 1-D overlaps, by nested quad."""
    (px0, px1), (py0, py1) = pixel
    (rx0, rx1), (ry0, ry1) = rect
    h, _, _ = airy_psf(na, wavelength * 1e6)  # [µm⁻²] with r in µm

    def across(u):
        return integrate.quad(lambda v: box_overlap(ry0, ry1, py0 - v, py1 - v)
                              * h(math.hypot(u, v)), py0 - ry1, py1 - ry0,
                              points=sorted({py0 - ry0, py1 - ry1}), epsabs=1e-13,
                              epsrel=1e-11, limit=200)[0]

    value = integrate.quad(lambda u: box_overlap(rx0, rx1, px0 - u, px1 - u) * across(u),
                           px0 - rx1, px1 - rx0, points=sorted({px0 - rx0, px1 - rx1}),
                           epsabs=1e-13, epsrel=1e-11, limit=200)[0]
    return value / ((px1 - px0) * (py1 - py0))


def lattice_cubes(pixel, rect, period, m=60):
    """Σ over the periodic copies (a·period, b·period), (a, b) ≠ 0, of D⁻³ [µm⁻³], D the
    distance between the pixel and the copy of the rectangle (boxes in µm): the (2m + 1)² block
    summed, the rest bounded by an integral: a copy beyond the block, at o, is at least
    |o| − s from the pixel (s the boxes' farthest separation), so at least |x| − c for every x
    of its p × p cell (c = s + half the cell's diagonal d), and those cells lie at |x| ≥
    R = (m + 1) p − d: Σ ≤ (1/p²) ∫_{|x| ≥ R} (|x| − c)⁻³ d²x = (2π/p²)(1/(R − c) +
    c/(2(R − c)²))."""
    (px0, px1), (py0, py1) = pixel
    (rx0, rx1), (ry0, ry1) = rect
    a, b = (k.ravel() for k in np.meshgrid(np.arange(-m, m + 1), np.arange(-m, m + 1)))
    a, b = a[(a != 0) | (b != 0)], b[(a != 0) | (b != 0)]
    sx, sy = b * period, a * period
    gx = np.maximum(0.0, np.maximum(rx0 + sx - px1, px0 - rx1 - sx))
    gy = np.maximum(0.0, np.maximum(ry0 + sy - py1, py0 - ry1 - sy))
    block = np.sum(np.hypot(gx, gy) ** -3.0)
    half_diagonal = period / math.sqrt(2)
    spread = math.hypot(max(px1, rx1) - min(px0, rx0), max(py1, ry1) - min(py0, ry0))
    c = half_diagonal + spread
    r = (m + 1) * period - half_diagonal
    return block + 2 * math.pi / period**2 * (1 / (r - c) + c / (2 * (r - c) ** 2))


def test_polychromatic_diffraction_converges_with_sub_bands():
    # nist-ir (working NA 0.2 at 5×, 6 µm pixels) with ideal electronics and a fill factor of
    # 1 (pixel footprints of whole samples: the reference integrates the exact pixel, and a
    # partial sample of the blurred field is a sampling error of its own, ~0.8 K here); its
    # band narrowed to the filter's support (3.78–5.12 µm, the same signal: the filter is 0
    # outside) so that all 64 sub-bands carry light (the preset's band would leave its edge
    # sub-bands out). A 6 × 12 µm hot spot of a shear band at 1300 K on a 500 K background,
    # the surroundings at 500 K: the hot light is bluer, so it spreads less than the cold
    # light. The scene (132 µm square) is large enough that radiosim's FFT padding is not
    # capped (at 4 scene lengths; the padding is ≤ 520 µm here), so its periodic copies of the
    # spot lie beyond the padding.
    n_side, na = 132, 0.2
    hot_rows, hot_cols = (60, 72), (63, 69)  # [µm] centred on a pixel corner: (66, 66)
    stack = np.full((1, n_side, n_side), 500.0)
    stack[0, slice(*hot_rows), slice(*hot_cols)] = 1300.0
    scene = rs.FrameStack(stack, dt=1e-6, dx=1e-6)
    scene.set_environment(surroundings_temperature=500.0)
    camera = nist_camera(band=FILTER_BAND)
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, fill_factor=1.0))
    assert camera.optics.object_na(camera.fpa) == pytest.approx(na, rel=1e-13)
    counts = [1, 2, 3, 4, 5, 6, 8, 12, 16, 32, 64]

    def apparent(n):
        return with_psf(camera, Diffraction(n)).measure(scene, 1e-6).apparent_temperature

    measured = {n: apparent(n) for n in counts}
    assert np.all(np.isfinite(measured[64]))

    # -- the reference: the pixels around the spot (a quarter; the rest by symmetry) --------
    window = [(i, j) for i in range(8, 11) for j in range(7, 11)]
    pixels = [((6.0 * j, 6.0 * j + 6), (6.0 * i, 6.0 * i + 6)) for i, j in window]
    rect = (hot_cols, hot_rows)
    curves = [shipped_curve(name) for name in NIST_CURVES]
    lo, hi = FILTER_BAND
    # E_p(λ), the fraction of the spot's excess radiance that pixel p sees, is analytic in λ:
    # interpolated from 16 Chebyshev nodes (12 nodes give the same temperatures to 1e-6 K).
    cheb = np.polynomial.chebyshev
    x = np.cos(math.pi * (np.arange(16) + 0.5) / 16)
    fractions = np.array([[rectangle_in_pixel(0.5 * (lo + hi) + 0.5 * (hi - lo) * xk, na, p,
                                              rect) for p in pixels] for xk in x])
    coefficients = cheb.chebfit(x, fractions, 15)

    def fraction(wavelength):
        return cheb.chebval((wavelength - 0.5 * (lo + hi)) / (0.5 * (hi - lo)), coefficients)

    full = spectral_rule(lo, hi, curves)

    def radiance(t):  # the in-band photon radiance of the whole band at t [K]
        return photon_radiance(full[0], t) @ full[1]

    def temperature(signal):
        return optimize.brentq(lambda t: radiance(t) - signal, 400.0, 1400.0, xtol=1e-10,
                               rtol=1e-14)

    def excess(nodes, weights):  # ∫ (L_q(1300 K) − L_q(500 K)) × curves over a rule
        return (photon_radiance(nodes, 1300.0) - photon_radiance(nodes, 500.0)) @ weights

    def sub_band_reference(n):
        # n equal sub-bands, each's light seen through the Airy pattern of its centre.
        edges = np.linspace(lo, hi, n + 1)
        signal = radiance(500.0) + sum(
            excess(*spectral_rule(a, b, curves)) * fraction(0.5 * (a + b))
            for a, b in zip(edges[:-1], edges[1:]))
        return np.array([temperature(s) for s in signal])

    reference = {n: sub_band_reference(n) for n in counts}
    continuous = radiance(500.0) + (
        (photon_radiance(full[0], 1300.0) - photon_radiance(full[0], 500.0)) * full[1]
    ) @ fraction(full[0]).T
    exact = np.array([temperature(s) for s in continuous])  # every wavelength its own PSF

    # -- 1. radiosim's image, sub-band count by count, against the reference ----------------
    # Its FFT is periodic: each pixel also sees the spot's copies, at multiples of the FFT
    # period ≥ the scene plus the padding P, the radius holding 1 − PAD_ENERGY of the Airy
    # light at the longest sub-band centre (≥ 4.45 µm, one sub-band's centre). Their light
    # only adds (1300 K > 500 K): the reading is the reference's, plus at most
    # A·λ/(π³ NA) Σ D⁻³ of the excess (the Airy envelope h ≤ 8 NA²/(λ² v³), v = 2π NA D/λ,
    # exceeded by < 1 % for v ≥ 10, its peaks falling as v grows; checked below up to twice
    # the nearest copies' v) over the copies' distances D, taken at
    # λ = 5.12 µm, through dT = dL / L'(T). Below: 1e-4 K for the radiance tables (1e-7 of L
    # each, over d ln L/dT ≥ 2.8e-3 K⁻¹).
    v_pad = optimize.brentq(lambda v: special.j0(v) ** 2 + special.j1(v) ** 2 - PAD_ENERGY,
                            1.0, 1e4)
    pad = v_pad * 4.45 / (2 * math.pi * na)  # [µm]
    assert 4 * n_side >= v_pad * hi * 1e6 / (2 * math.pi * na) + 2  # padding not capped
    period = n_side + pad
    v = np.linspace(10.0, 2 * math.pi * na * 2 * period / 3.78, 200_001)
    assert np.max((2 * special.j1(v) / v) ** 2 * math.pi * v**3 / 8) < 1.01
    area = (hot_cols[1] - hot_cols[0]) * (hot_rows[1] - hot_rows[0])
    share = np.array([1.01 * area * hi * 1e6 / (math.pi**3 * na) * lattice_cubes(p, rect, period)
                      for p in pixels])
    assert 2 * math.pi * na * pad / (hi * 1e6) > 10  # every copy ≥ P away: v > 10
    rows, cols = np.array(window).T
    for n in counts:
        # L is convex: its slope at the reference bounds the slope up to the reading.
        slope = np.array([(radiance(t + 1e-3) - radiance(t - 1e-3)) / 2e-3
                          for t in reference[n]])
        copies = share * excess(*full) / slope  # [K]
        difference = measured[n][rows, cols] - reference[n]
        assert np.all(difference > -1e-4), (n, difference)
        assert np.all(difference < copies + 1e-4), (n, difference, copies)

    # -- 2. the sub-band count that keeps 0.1 K, derived from the reference -----------------
    # The reference's own error (n sub-bands against every wavelength its own PSF) gives the
    # smallest count from which every count tested stays below 0.1 K; radiosim's errors,
    # against its own 64 sub-bands over every pixel, must need the same count.
    truth = {n: float(np.max(np.abs(reference[n] - exact))) for n in counts}
    errors = {n: float(np.max(np.abs(measured[n] - measured[64]))) for n in counts}
    needed = min(n for n in counts if all(truth[m] < 0.1 for m in counts if m >= n))
    enough = min(n for n in counts if all(errors[m] < 0.1 for m in counts if m >= n))
    assert 1 < needed < 64 and enough == needed, (truth, errors)
    # The error falls steadily (about as 1/n²) and one sub-band is off by kelvins.
    assert errors[1] > 1.0
    assert errors[2] < errors[1] / 3 and errors[4] < errors[2] / 3 and errors[8] < errors[4] / 3


# -- 6. scatter halo: the size-of-source effect ----------------------------------------------


def disc_stack(n, dx, radius, cold, hot, sub=16):
    """A uniform disc of ``radius`` [m] centred on an n × n grid (n odd), each sample holding
    cold + (hot − cold) × the disc's area fraction in it (sub × sub sub-samples)."""
    x = (np.arange(n * sub) + 0.5) / sub * dx - n * dx / 2
    inside = (x[:, None] ** 2 + x[None, :] ** 2 <= radius**2)
    fraction = inside.reshape(n, sub, n, sub).mean(axis=(1, 3))
    return (cold + (hot - cold) * fraction)[None], fraction.sum() * dx * dx


@pytest.mark.parametrize("radius", [5e-6, 15e-6, 30e-6, 60e-6])
def test_scatter_halo_gives_the_size_of_source_effect_of_a_disc(radius):
    # A linear camera with a ScatterHalo (β = 0.2, a = 30 µm): h = (1 − β) δ + β a/(2π
    # (r² + a²)^{3/2}). The centre pixel (3 µm, wholly inside the disc) of a uniform disc of
    # radius R on a background at the surroundings' temperature reads the excess fraction
    # (1 − β) + β (1 − a/√(R² + a²)) (the halo's encircled energy).
    beta, a = 0.2, 30e-6
    dx, pitch, n = 1e-6, 3e-6, 303
    cold, hot = 300.0, 800.0
    stack, area = disc_stack(n, dx, radius, cold, hot)
    scene = rs.FrameStack(stack, dt=1e-6, dx=dx)
    scene.set_environment(surroundings_temperature=cold)
    image = one_frame(linear_camera(pitch, ScatterHalo(beta, a)), scene)
    k = image.shape[0] // 2
    fraction = (image[k, k] - cold) / (hot - cold)
    expected = (1 - beta) + beta * (1 - a / math.sqrt(radius**2 + a**2))
    assert float(halo_encircled_energy(radius, a)) == pytest.approx(
        1 - a / math.sqrt(radius**2 + a**2), rel=1e-14)

    def halo(r):
        return a / (2 * math.pi * (r * r + a * a) ** 1.5)

    # Tolerance, term by term:
    # - the pixel's size: the pixel averages the halo-blurred disc over p², which shifts it by
    #   (p²/24) ∇²(h ⊛ disc) = (p²/24) ∮ ∂h/∂n = (p²/24) 2πR |h'(R)|;
    slope = 3 * a * radius / (2 * math.pi * (radius**2 + a**2) ** 2.5)
    pixel = beta * pitch**2 / 24 * 2 * math.pi * radius * slope
    # - the disc's staircase: its sampled area differs from πR² by ΔA near r = R;
    staircase = beta * halo(radius) * abs(area - math.pi * radius**2)
    # - periodic copies of the disc (FFT period ≥ 2 n dx each way) add β A h(D) each.
    period = 2 * n * dx
    wrap = beta * area * sum(halo(period * math.hypot(i, j)) for i in range(-30, 31)
                             for j in range(-30, 31) if (i, j) != (0, 0))
    tolerance = 1.5 * (pixel + staircase + wrap)
    assert fraction == pytest.approx(expected, abs=tolerance)
    # the size-of-source effect itself is far larger than the tolerance
    assert beta * a / math.sqrt(radius**2 + a**2) > 100 * tolerance


# -- the sampled blur against the exact sample-square kernel ---------------------------------


def gaussian_sample_kernel(sigma, dx, n=3):
    """The exact per-axis kernel of a Gaussian blur between sample-square averages:
    K[m] = ∫ tri(m − x/dx) g(x) dx (box ⊛ box = the triangle), by quadrature."""
    def g(x):
        return math.exp(-x * x / (2 * sigma * sigma)) / (math.sqrt(2 * math.pi) * sigma)

    return np.array([integrate.quad(lambda x: max(0.0, 1 - abs(m - x / dx)) * g(x),
                                    (m - 1) * dx, (m + 1) * dx,
                                    points=sorted({(m - 1) * dx, m * dx, 0.0, (m + 1) * dx}),
                                    epsabs=1e-15, epsrel=1e-13, limit=200)[0]
                     for m in range(-n, n + 1)])


@pytest.mark.parametrize("ratio", [
    0.02, 0.1, 0.25, 0.5, 1.0, 2.0])
def test_gaussian_blur_equals_the_exact_sample_kernel(ratio):
    # One hot sample through GaussianBlur(σ = ratio · dx): the blurred sample averages are
    # the separable kernel K[m] K[n] (module docstring of radiosim.psf), here by quadrature
    # in real space. The alias sum is exact where it keeps every alias with H > 1e-13:
    # 1e-9 of the sample's value asserted.
    dx = 1e-6
    field = np.zeros((15, 15))
    field[7, 7] = 1.0
    out = blur(field, 0.0, [GaussianBlur(ratio * dx)], dx, LAMBDA, 0.2)
    kernel = gaussian_sample_kernel(ratio * dx, dx)
    np.testing.assert_allclose(out[4:11, 4:11], np.outer(kernel, kernel), rtol=0, atol=1e-9)


def test_a_point_like_tabulated_psf_leaves_the_samples_alone():
    # A measured PSF of one 1 nm cell is a point for 1 µm samples: the exact kernel is
    # K[0] = ∫ tri(x/dx) box(x) dx = 1 − pitch/(4 dx) per axis, the rest ≤ pitch/(8 dx):
    # unchanged to 1e-3.
    field = np.zeros((15, 15))
    field[7, 7] = 1.0
    out = blur(field, 0.0, [TabulatedPSF(np.ones((1, 1)), 1e-9)], 1e-6, LAMBDA, 0.2)
    np.testing.assert_allclose(out, field, rtol=0, atol=1e-3)


# -- 9. bad PSF inputs and camera files ------------------------------------------------------


def test_unknown_psf_type_in_a_camera_file_is_refused(tmp_path):
    text = rs.Camera.preset("nist-ir").to_toml().replace(
        "[fpa]", '[[optics.psf]]\ntype = "zernike"\nsigma_um = 1.0\n\n[fpa]')
    (tmp_path / "camera.toml").write_text(text)
    with pytest.raises(RadiosimError, match="unknown PSF type 'zernike'.*diffraction"):
        rs.Camera.from_toml(tmp_path / "camera.toml")
    with pytest.raises(RadiosimError, match="unknown PSF type 'airy'"):
        as_psf({"type": "airy"})
    with pytest.raises(RadiosimError, match="unknown keys.*sigma"):
        as_psf({"type": "diffraction", "sigma_um": 2.0})
    with pytest.raises(RadiosimError, match="must be a number"):
        as_psf({"type": "gaussian", "sigma_um": "2"})
    with pytest.raises(RadiosimError, match="table with a type"):
        as_psf([{"sigma_um": 2.0}])


def test_bad_psf_parameters_are_refused(tmp_path):
    with pytest.raises(RadiosimError, match="2-D array.*\\(3, 3, 3\\)"):
        TabulatedPSF(np.ones((3, 3, 3)), 1e-6)
    with pytest.raises(RadiosimError, match="finite values ≥ 0"):
        TabulatedPSF(np.array([[1.0, -1.0]]), 1e-6)
    missing = tmp_path / "measured_psf.csv"
    with pytest.raises(RadiosimError, match="measured_psf.csv does not exist"):
        TabulatedPSF(missing, 1e-6)
    with pytest.raises(RadiosimError, match="sub_bands"):
        Diffraction(0)
    with pytest.raises(RadiosimError, match="sub_bands"):
        Diffraction(2.5)
    with pytest.raises(RadiosimError, match="sigma"):
        GaussianBlur(-1e-6)
    with pytest.raises(RadiosimError, match="fraction"):
        ScatterHalo(1.5, 10e-6)
    # A missing PSF file named in a camera file (relative to it).
    text = rs.Camera.preset("nist-ir").to_toml().replace(
        "[fpa]", '[[optics.psf]]\ntype = "tabulated"\nfile = "measured_psf.csv"\n'
                 'pitch_um = 0.5\n\n[fpa]')
    (tmp_path / "camera.toml").write_text(text)
    with pytest.raises(RadiosimError, match="measured_psf.csv does not exist"):
        rs.Camera.from_toml(tmp_path / "camera.toml")


def test_camera_file_round_trip_keeps_the_psfs(tmp_path):
    camera = nist_camera((Diffraction(5), GaussianBlur(1.5e-6), ScatterHalo(0.03, 80e-6)),
                         instrument_temperature=305.0)
    path = tmp_path / "camera.toml"
    path.write_text(camera.to_toml())
    assert path.read_text().count("[[optics.psf]]") == 3
    back = rs.Camera.from_toml(path)
    assert back.optics.psf == camera.optics.psf
    assert back.optics.instrument_temperature == 305.0
    assert back.to_toml() == camera.to_toml()
    # A tabulated PSF from a CSV file beside the camera file, normalised to unit sum.
    kernel = np.array([[0.0, 1.0, 0.0], [1.0, 4.0, 1.0], [0.0, 1.0, 0.0]])
    np.savetxt(tmp_path / "psf.csv", kernel, delimiter=",")
    path.write_text(camera.to_toml().replace(
        "[fpa]", '[[optics.psf]]\ntype = "tabulated"\nfile = "psf.csv"\npitch_um = 0.5\n\n[fpa]'))
    tabulated = rs.Camera.from_toml(path).optics.psf[-1]
    assert isinstance(tabulated, TabulatedPSF) and tabulated.pitch == pytest.approx(0.5e-6)
    np.testing.assert_allclose(tabulated.kernel, kernel / 8, rtol=1e-15)

"""Radiometry against independent references: quadrature, closed forms, CODATA."""

import math

import numpy as np
import pytest
import scipy.constants as sc
from scipy.integrate import quad

from radiosim.errors import RadiosimError
from radiosim.radiometry import (
    PLANCK_C1,
    PLANCK_C2,
    TABLE_C_DU,
    BandRadianceTable,
    band_radiance,
    blackbody_fraction,
    planck_spectral_radiance,
)
from radiosim.spectral import read_spectrum, spectral_distribution

ZETA3 = 1.2020569031595942  # Apéry's constant ζ(3)
CAMERA_CURVES = ["filter_mwir_3.8-5.1um", "optics_mwir_lens", "qe_insb_77K"]


def test_second_radiation_constant_is_codata_not_its90():
    assert PLANCK_C2 == sc.h * sc.c / sc.k
    assert abs(PLANCK_C2 - 0.014388) > 1e-7  # ITS-90's rounded value differs


@pytest.mark.parametrize("quantity", ["photon", "energy"])
@pytest.mark.parametrize("temperature", [250.0, 600.0, 1012.15, 2500.0])
def test_band_radiance_matches_adaptive_quadrature(quantity, temperature):
    def integrand(wl):
        return float(planck_spectral_radiance(wl, temperature, quantity))

    reference, _ = quad(integrand, 3.8e-6, 5.1e-6, epsabs=0, epsrel=1e-13, limit=200)
    assert band_radiance(temperature, quantity=quantity) == pytest.approx(reference, rel=1e-11)


@pytest.mark.parametrize("temperature", [300.0, 1000.0, 2500.0])
def test_wide_band_tends_to_stefan_boltzmann(temperature):
    band = (5e-8, 5e-3)
    total = sc.Stefan_Boltzmann * temperature**4 / np.pi
    # What the band misses on either side, from the blackbody-fraction series:
    missing = blackbody_fraction(band[0] * temperature) + 1 - blackbody_fraction(
        band[1] * temperature)
    value = band_radiance(temperature, band=band, quantity="energy")
    assert value / total == pytest.approx(1 - missing, rel=1e-10)
    assert missing < 1e-6  # so the band holds σT⁴/π to better than 1e-6


def test_total_photon_radiance_closed_form():
    # ∫ 2c/λ⁴ / (e^{hc/λkT} − 1) dλ = 2c (kT/hc)³ · 2ζ(3)
    temperature, upper = 1000.0, 1e-2
    closed = 2 * sc.c * (sc.k * temperature / (sc.h * sc.c)) ** 3 * 2 * ZETA3
    x = PLANCK_C2 / (upper * temperature)
    tail = x**2 / 2 / (2 * ZETA3)  # fraction beyond `upper`: ∫₀ˣ t²/(eᵗ−1) dt ≈ x²/2
    value = band_radiance(temperature, band=(1e-8, upper), quantity="photon")
    assert value / closed == pytest.approx(1 - tail, rel=1e-9)


def test_photon_and_energy_units_are_consistent():
    temperature = 900.0
    # Mean photon energy of the full spectrum is π⁴/(30 ζ(3)) kT.
    band = (1e-8, 1e-2)
    ratio = band_radiance(temperature, band, "energy") / band_radiance(temperature, band)
    assert ratio / (sc.k * temperature) == pytest.approx(np.pi**4 / (30 * ZETA3), rel=1e-5)
    # In a narrow band every photon carries hc/λ: error of order (Δλ/λ)².
    wl, half = 4.0e-6, 2e-10
    energy = band_radiance(temperature, (wl - half, wl + half), "energy")
    photon = band_radiance(temperature, (wl - half, wl + half), "photon")
    assert energy / photon == pytest.approx(sc.h * sc.c / wl, rel=1e-8)


def test_blackbody_fraction_matches_independent_quadrature():
    lt = np.array([5e-4, 1e-3, 2e-3, 2.8977719e-3, 5e-3, 7.19e-3, 7.2e-3, 1e-2, 5e-2])
    fraction = blackbody_fraction(lt)
    for value, product in zip(fraction, lt):
        x = PLANCK_C2 / product
        below, _ = quad(lambda t: t**3 / math.expm1(t), x, 60 + x, epsabs=0, epsrel=1e-13)
        assert value == pytest.approx(15 / np.pi**4 * below, rel=1e-11, abs=1e-15)
    # A quarter of the exitance lies below Wien's peak wavelength.
    assert float(blackbody_fraction(sc.Wien)) == pytest.approx(0.25005, abs=5e-6)


def test_band_radiance_equals_fraction_difference():
    temperature = np.array([400.0, 1200.0])
    band = (3.8e-6, 5.1e-6)
    expected = sc.Stefan_Boltzmann * temperature**4 / np.pi * (
        blackbody_fraction(band[1] * temperature) - blackbody_fraction(band[0] * temperature))
    assert band_radiance(temperature, band, "energy") == pytest.approx(expected, rel=1e-11)


def test_wien_displacement():
    temperature = 1000.0
    wl = np.linspace(2.5e-6, 3.3e-6, 80001)
    peak = wl[np.argmax(planck_spectral_radiance(wl, temperature))]
    assert peak * temperature == pytest.approx(sc.Wien, abs=2e-11 * temperature)


def test_planck_law_agrees_with_colour_science_and_hand_written_planck():
    # Two independent implementations: colour-science's CIE 015:2004 planck_law (with the
    # CODATA radiation constants passed in) and Planck's law written here from h, c, k.
    from colour.colorimetry import planck_law

    wl = np.linspace(1e-6, 20e-6, 97)
    t = np.array([150.0, 293.15, 800.0, 3000.0])
    ours = planck_spectral_radiance(wl, t)
    theirs = planck_law(wl, t, c1=PLANCK_C1, c2=PLANCK_C2).T
    np.testing.assert_array_equal(ours, theirs)  # same formula, same operations: same bits
    by_hand = 2 * sc.h * sc.c**2 / wl**5 / np.expm1(sc.h * sc.c / (wl * sc.k * t[:, None]))
    np.testing.assert_allclose(ours, by_hand, rtol=1e-13)


def test_planck_spectral_radiance_shapes():
    out = planck_spectral_radiance(np.array([4e-6, 5e-6, 6e-6]), np.full((2, 4), 500.0))
    assert out.shape == (2, 4, 3)


def test_grey_factors_scale_and_spectral_weights_weigh():
    t = 800.0
    base = band_radiance(t)
    assert band_radiance(t, emissivity=0.3) == pytest.approx(0.3 * base, rel=1e-14)
    assert band_radiance(t, responsivity=[0.5, 0.4]) == pytest.approx(0.2 * base, rel=1e-14)
    flat = spectral_distribution([3e-6, 6e-6], [0.5, 0.5])
    assert band_radiance(t, responsivity=flat) == pytest.approx(0.5 * base, rel=1e-12)


@pytest.mark.parametrize("emissivity", [1.0, "emissivity_steel_clean"])
def test_table_relative_error_below_1e6_over_200_2500K(emissivity):
    band = (3.75e-6, 5.15e-6)
    curves = [read_spectrum(n) for n in CAMERA_CURVES]
    table = BandRadianceTable(band, responsivity=curves, emissivity=emissivity)
    t = np.concatenate([np.linspace(200, 2500, 4001),
                        np.random.default_rng(3).uniform(200, 2500, 2000)])
    reference = band_radiance(t, band, responsivity=curves, emissivity=emissivity)
    assert np.max(np.abs(table(t) / reference - 1)) < 1e-6
    # and its inverse recovers the temperature
    assert np.max(np.abs(table.temperature(reference) - t)) < 1e-6


def test_table_energy_quantity_and_out_of_range():
    table = BandRadianceTable(quantity="energy", temperature_range=(200, 1500))
    assert table.unit == "W m-2 sr-1"
    with pytest.raises(RadiosimError, match="outside the radiance table's range"):
        table(np.array([500.0, 1600.0]))
    with pytest.raises(RadiosimError, match="outside"):
        table(np.array([np.nan]))
    lo, hi = table.radiance_range
    assert np.isnan(table.temperature(np.array([0.5 * lo, 2 * hi, -1.0]))).all()


@pytest.mark.parametrize("bad", [np.nan, -5.0, 0.0])
def test_bad_temperature_is_named(bad):
    with pytest.raises(RadiosimError, match="temperature"):
        band_radiance(np.array([300.0, bad]))


def test_bad_band_and_quantity():
    with pytest.raises(RadiosimError, match="band"):
        band_radiance(300.0, band=(5.1, 3.8))
    with pytest.raises(RadiosimError, match="band upper edge"):
        band_radiance(300.0, band=(3.8e-6, 5.1))
    with pytest.raises(RadiosimError, match="quantity"):
        band_radiance(300.0, quantity="lumens")


def test_blackbody_fractions_match_the_published_table():
    from radiosim.radiometry import BLACKBODY_FRACTION_TABLE

    lt_um = np.array(list(BLACKBODY_FRACTION_TABLE), dtype=float)
    published = np.array(list(BLACKBODY_FRACTION_TABLE.values()))
    fraction = blackbody_fraction(lt_um * 1e-6)
    # Table rounding (5e-6) plus its c₂ = 14388 µm K: |dF/d ln λT|·Δc₂/c₂ ≤ 0.66 × 1.6e-5.
    x = PLANCK_C2 / (lt_um * 1e-6)
    slope = 15 / np.pi**4 * x**4 / np.expm1(x)
    tolerance = 5e-6 + slope * (14388e-6 - PLANCK_C2) / PLANCK_C2 + 1e-7
    assert np.all(np.abs(fraction - published) <= tolerance)


def test_nist_ir_table_over_130_4000K_against_quadrature_and_its_own_inverse():
    # The Planck response's table: L cubic in T, 2048 intervals per octave for T_min = 100 K
    # (c ΔT/T² ≤ 0.03 there, TABLE_C_DU), error of order 5/384 (c ΔT/T²)⁴ ≈ 1e-8 at the cold
    # end; measured 2e-11. Asserted: 1e-8 (the documented bound is 1e-6).
    band = (3.75e-6, 5.15e-6)
    curves = [read_spectrum(n) for n in CAMERA_CURVES]
    table = BandRadianceTable(band, responsivity=curves, temperature_range=(100.0, 4000.0))
    rng = np.random.default_rng(5)
    t = np.concatenate([np.linspace(130, 4000, 8001), rng.uniform(130, 4000, 4000),
                        1 / rng.uniform(1 / 4000, 1 / 130, 4000), [130.0, 4000.0]])
    reference = band_radiance(t, band, responsivity=curves)
    assert np.max(np.abs(table(t) / reference - 1)) < 1e-8
    # Forward and inverse are the same cubic: consistent to rounding (≈ 1e-11 K).
    assert np.max(np.abs(table.temperature(table(t)) - t)) < 1e-9
    # The numpy evaluation is the kernels' oracle: same result in any chunking, float32 in.
    t32 = t.astype(np.float32)
    np.testing.assert_array_equal(table.evaluate_reference(t32),
                                  table.evaluate_reference(t32.astype(np.float64)))


def test_table_grid_is_the_floats_with_their_top_mantissa_bits():
    table = BandRadianceTable(temperature_range=(200.0, 1500.0), per_octave=64)
    # 64 intervals per octave: 128–256 K by 2 K, 256–512 K by 4 K, …, 1024–2048 K by 16 K;
    # the range's intervals 200–202 … 1488–1504 K plus 12 past each end.
    t = table.temperatures
    assert (t[12], t[-13]) == (200.0, 1504.0) and (t[0], t[-1]) == (176.0, 1696.0)
    step = np.diff(t)
    octave = 2.0 ** np.floor(np.log2(t[:-1]))
    np.testing.assert_array_equal(step, octave / 64)
    assert table.intervals == t.size - 1 and table.coefficients.shape == (table.intervals, 4)
    # The interval of T is read off its bits; its node is T with the other bits cleared.
    samples = np.array([200.0, 201.999, 1000.5, 1503.9])
    index, d = table._locate(samples)
    np.testing.assert_array_equal(t[index], [200.0, 200.0, 1000.0, 1488.0])
    np.testing.assert_array_equal(d, samples - t[index])
    # The default: the fewest intervals per octave with c₂ 2⁻ᵐ/(λ₁ T_min) ≤ 0.03.
    c = PLANCK_C2 / 3.8e-6
    assert BandRadianceTable(temperature_range=(150.0, 3000.0)).per_octave == 1024
    assert c / 150.0 / 1024 <= TABLE_C_DU < c / 150.0 / 512
    for bad in (2, 100, 3.5, True, np.nan, np.inf, 2**21, "64"):
        with pytest.raises(RadiosimError, match="per_octave must be a power of two"):
            BandRadianceTable(per_octave=bad)
    with pytest.raises(RadiosimError, match="would hold 20874393 intervals"):
        BandRadianceTable(temperature_range=(1.0, 1e6), per_octave=2**20)
    # A coarse table's cold margin stays within an octave (the band keeps radiance there).
    coarse = BandRadianceTable(temperature_range=(25.0, 300.0), per_octave=4)
    assert coarse.temperatures[0] == 12.0

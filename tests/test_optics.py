"""The optics stage: étendue, the objective's numerical aperture, the working f-number."""

import math

import numpy as np
import pytest

from radiosim import Camera
from radiosim.errors import RadiosimError
from radiosim.fpa import FocalPlaneArray
from radiosim.optics import Optics, collect, etendue, f_number_of


def test_etendue_is_area_times_projected_solid_angle():
    # Cone of half-angle θ: projected solid angle π sin²θ, and sin θ = 1/√(4N² + 1).
    for n in (0.7, 1.0, 2.5, 4.0):
        theta = math.asin(1 / math.sqrt(4 * n**2 + 1))
        assert etendue(2e-10, n) == pytest.approx(2e-10 * math.pi * math.sin(theta) ** 2)


def test_etendue_tends_to_the_hemisphere():
    # The projected solid angle of the whole hemisphere is π sr.
    assert etendue(1.0, 1e-6) == pytest.approx(math.pi, rel=1e-10)
    assert etendue(1.0, 0.5) == pytest.approx(math.pi / 2, rel=1e-15)


@pytest.mark.parametrize("sine", [0.04, 0.196, 0.5, 0.9])
def test_f_number_of_inverts_the_cone_relation(sine):
    n = f_number_of(sine)
    assert 1 / math.sqrt(4 * n * n + 1) == pytest.approx(sine, rel=1e-13)


def test_objective_na_limits_the_cone_by_the_sine_condition():
    fpa = FocalPlaneArray(6e-6, detector_pitch=30e-6, fill_factor=0.85)  # m = 5
    optics = Optics(f_number=2.5, objective_na=0.2)
    # Image-side sin θ' = NA / m = 0.04, narrower than the f/2.5 stop's 1/√26.
    sine = 0.2 / 5
    assert optics.etendue(fpa) == pytest.approx(fpa.active_area * math.pi * sine**2, rel=1e-13)
    assert optics.object_na(fpa) == pytest.approx(0.2, rel=1e-13)
    # A wide objective leaves the cold stop in charge.
    wide = Optics(f_number=2.5, objective_na=0.99)
    assert wide.image_f_number(fpa) == 2.5
    # Without an objective the stop alone: at 5× an f/2.5 stop means an object NA of 0.98.
    assert Optics(f_number=2.5).object_na(fpa) == pytest.approx(5 / math.sqrt(26), rel=1e-13)


def test_nist_ir_preset_is_a_plausible_microscope():
    cam = Camera.preset("nist-ir")
    assert cam.optics.object_na(cam.fpa) <= 0.3  # a dry IR objective, not the 0.98 of f/2.5
    # The converter's top code starts exactly at the full well.
    el = cam.electronics
    assert el.gain * el.full_well + el.offset == pytest.approx(el.max_count - 0.5, abs=1e-9)
    assert el.saturation_charge == pytest.approx(el.full_well, rel=1e-12)


def test_photoelectrons_of_a_blackbody_match_planck_quadrature_times_etendue_and_time():
    # Independent of the chain: N_e = ∫ L_q(λ, T) dλ · A_active · π/(4N² + 1) · t, with the
    # photon Planck law written out (SI 2019 constants) and integrated by adaptive quadrature.
    from scipy.integrate import quad

    from radiosim.electronics import Electronics
    from radiosim.scenes import UniformBlackbody

    h, c, k = 6.62607015e-34, 299792458.0, 1.380649e-23
    temperature, f_number, t_int = 900.0, 2.0, 10e-6
    camera = Camera(fpa=FocalPlaneArray(pixel_pitch=6e-6, shape=(4, 4), fill_factor=0.8),
                    optics=Optics(f_number=f_number, transmission=1.0),
                    electronics=Electronics.ideal(), response="planck")
    electrons = camera.measure(UniformBlackbody(temperature), t_int).electrons
    radiance = quad(lambda lam: 2 * c / lam**4 / math.expm1(h * c / (lam * k * temperature)),
                    3.8e-6, 5.1e-6, epsabs=0, epsrel=1e-12)[0]
    expected = radiance * (6e-6) ** 2 * 0.8 * math.pi / (4 * f_number**2 + 1) * t_int
    # The response's radiance table is within 1e-7 of quadrature (response.py); nothing else
    # in a noise-free ideal chain approximates.
    np.testing.assert_allclose(electrons, expected, rtol=1e-7)
    # collect is that product: mean signal × rate per signal × time.
    assert collect(radiance, camera.rate_per_signal, t_int) == pytest.approx(expected, rel=1e-7)


@pytest.mark.parametrize("bad", [dict(objective_na=1.2), dict(objective_na=0.0),
                                 dict(f_number=-1), dict(band=(5e-6, 4e-6)),
                                 dict(f_number="2.5")])
def test_bad_optics_are_refused(bad):
    with pytest.raises(RadiosimError):
        Optics(**bad)

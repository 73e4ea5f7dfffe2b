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


def test_collect_is_signal_times_rate_times_time():
    signal = np.array([[1.0e20, 2.0e20]])
    assert collect(signal, 3e-12, 1e-5).tolist() == (signal * 3e-12 * 1e-5).tolist()


@pytest.mark.parametrize("bad", [dict(objective_na=1.2), dict(objective_na=0.0),
                                 dict(f_number=-1), dict(band=(5e-6, 4e-6)),
                                 dict(f_number="2.5")])
def test_bad_optics_are_refused(bad):
    with pytest.raises(RadiosimError):
        Optics(**bad)

"""
The real Cedip Jade LWIR recording of a 150 °C blackbody and the camera that reads it (pyradi's
files, MIT licence: ``tests/data/ptw/SOURCE.md``), shared by the validation notebooks 08 and 09
and the tests: the camera as its calibration file describes it, and fitted to its two
calibration tables with the instrument factor free.
"""

from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "ptw"
RECORDING = DATA / "LWIR-BBref-150C-150us.ptw"
PITCH = 30e-6  # the Jade's pixel [m], at magnification 1
INTEGRATION_TIME = 150e-6  # [s]
#: The camera's calibration tables: blackbody temperatures [°C] and the counts [DN] at housing
#: temperatures of 17.1 °C and 34.4 °C.
TABLE_C = np.array([50, 100, 150, 200, 250, 300, 350, 400, 450.0])
COUNTS_17 = [4571, 5132, 5906, 6887, 8034, 9338, 10834, 12386, 14042]
COUNTS_34 = [5477, 6050, 6817, 7789, 8922, 10262, 11694, 13299, 14921]
HOUSING_K = (17.1 + 273.15, 34.4 + 273.15)


def curve(name):
    """One of the camera's spectral curves (µm, value), as a colour-science distribution."""
    from colour import SpectralDistribution

    rows = np.array([[float(v) for v in line.split()[:2]]
                     for line in (DATA / name).read_text().splitlines() if line.strip()])
    keep = np.concatenate([[True], np.diff(rows[:, 0]) > 0])
    return SpectralDistribution(dict(zip(rows[keep, 0] * 1e-6, rows[keep, 1])), name=name)


def camera():
    """The Jade LWIR as its calibration file describes it: 30 µm pixels, fill factor 0.7,
    f/2, the lens and the ND filter in the filter slot, the detector's relative response as
    its quantum efficiency (the absolute scale is the fitted gain's)."""
    from colour import SpectralDistribution

    from radiosim import Camera

    lens, nd = curve("LW100mmLens.txt"), curve("LWND10.txt")
    lam = np.linspace(6.9e-6, 13.5e-6, 400)
    slot = SpectralDistribution(dict(zip(lam, np.interp(lam, lens.wavelengths, lens.values)
                                         * np.interp(lam, nd.wavelengths, nd.values))),
                                name="lens × ND 10 %")
    base = Camera.preset("nist-ir")
    return base.replace(
        name="jade-lwir",
        optics=replace(base.optics, band=(7.0e-6, 13.0e-6), spectral_filter=slot,
                       transmission=1.0, f_number=2.0, objective_na=None, psf=None),
        fpa=replace(base.fpa, pixel_pitch=PITCH, detector_pitch=PITCH, fill_factor=0.7,
                    shape=(240, 320), quantum_efficiency=curve("LWIRsensor.txt")),
        electronics=replace(base.electronics, full_well=1e12, dark_current=0.0, gain=1e-6,
                            offset=0.0, adc_bits=14),
        calibration_range=(250.0, 800.0))


@cache
def fitted_camera():
    """:func:`camera` fitted to both tables with the instrument factor free; and the fit's
    residuals [DN]."""
    from radiosim.calibration import fit_calibration

    return fit_calibration(camera(), np.concatenate([TABLE_C, TABLE_C]) + 273.15,
                           np.array(COUNTS_17 + COUNTS_34, dtype=float), INTEGRATION_TIME,
                           instrument_temperatures=np.repeat(HOUSING_K, 9))

"""The physics reference's figures (docs/_static/*.png): run `python docs/make_figures.py`."""

from pathlib import Path

import numpy as np

import radiosim as rs
from radiosim.characterization import size_of_source
from radiosim.plotting import figure, save_figure
from radiosim.psf import transfer

STATIC = Path(__file__).resolve().parent / "_static"


def radiance_figure():
    camera = rs.Camera.preset("nist-ir")
    response = camera.response_model
    t = np.linspace(250.0, 1600.0, 300)
    signal = response.grey_signal(t)
    fig = figure(7, 3.4)
    ax1, ax2 = fig.subplots(1, 2)
    ax1.semilogy(t - 273.15, signal)
    ax1.set(xlabel="blackbody temperature [°C]", ylabel="in-band photon radiance\n"
            "[photons s⁻¹ m⁻² sr⁻¹]", title="nist-ir: 3.8–5.1 µm")
    ax2.plot(t - 273.15, response.slope(t) * t / signal)
    ax2.set(xlabel="blackbody temperature [°C]", ylabel="d ln L / d ln T",
            title="how steeply radiance rises")
    save_figure(fig, STATIC / "radiance.png")


def optics_figure():
    psf_camera = rs.Camera.preset("nist-ir-psf")
    na = psf_camera.optics.object_na(psf_camera.fpa)
    f = np.linspace(0.0, 1.1 * 2 * na / 3.8e-6, 400)
    fig = figure(7, 3.4)
    ax1, ax2 = fig.subplots(1, 2)
    for wavelength in (3.8e-6, 4.45e-6, 5.1e-6):
        h = transfer(psf_camera.optics.psf, f, 0.0 * f, wavelength, na)
        ax1.plot(f * 1e-3, np.real(h), label=f"{wavelength * 1e6:.2f} µm")
    pitch = psf_camera.fpa.pixel_pitch
    ax1.axvline(0.5e-3 / pitch, color="0.6", lw=0.8)
    ax1.set(xlabel="spatial frequency [cycles/mm]", ylabel="MTF",
            title="diffraction × 2 % halo (object space)")
    ax1.legend()
    d = pitch * np.geomspace(2, 200, 13)
    curve = size_of_source(psf_camera, d)
    ax2.semilogx(d * 1e6, curve.sse, "o-")
    ax2.set(xlabel="disc diameter [µm]", ylabel="SSE", title="size-of-source effect")
    save_figure(fig, STATIC / "optics.png")


if __name__ == "__main__":
    radiance_figure()
    optics_figure()

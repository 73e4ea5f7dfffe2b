"""
Point-spread functions of the optics, as optical transfer functions in object space, and the
exact blur of a sampled radiance field.

A scene sample (i, j) is a square of side dx with uniform radiance (the convention of
:mod:`radiosim.scenes.base`). The optics spread radiance by a point-spread function h; the
integrator then averages the blurred field over each pixel's footprint, and it does so from the
field's averages over the sample squares. Those averages are the samples convolved with the
discrete kernel K[n] = (box ⊛ box ⊛ h)(n·dx) / dx², whose transfer function (per axis) is the
alias sum

    K̂(f) = Σ_k sinc²((f + k/dx)·dx) · H(f + k/dx),

with H the optical transfer function (OTF) [1] at object-space spatial frequency f
[cycles m⁻¹]. Because Σ_k sinc²(f·dx + k) = 1, a perfect lens (H ≡ 1) changes nothing, and a
uniform field is unchanged by any PSF (H(0) = 1: energy is conserved). The sum is evaluated over
the aliases where H differs from its limit at infinite frequency (:attr:`PSF.floor`): exact for
band-limited OTFs (diffraction), truncated at 1e-13 of H for the others within ±4 aliases. A
Gaussian or a tabulated PSF alone (or Gaussians only) factorises per axis, and its sum runs
over every alias it needs (at most 20 000 either side: within 1e-5 for a PSF far narrower than
a sample); any other PSF narrower than the samples allow
within ±4 aliases is blurred approximately, with a warning.

Models (each one published closed form):

-   :class:`Diffraction`: the incoherent OTF of an aberration-free circular pupil,
    H(ν) = (2/π)(arccos ν − ν√(1 − ν²)), ν = f/f_c, cut-off f_c = 2 NA/λ in object space
    (NA the object-side numerical aperture of the working cone, see
    :meth:`radiosim.optics.Optics.object_na`); polychromatic through spectral sub-bands.
-   :class:`GaussianBlur`: H = exp(−2π²σ²f²), aberrations and defocus lumped.
-   :class:`ScatterHalo`: a fraction β of the light scattered into a wide halo with power-law
    wings, h(r) = a / (2π (r² + a²)^(3/2)) (the 2-D Poisson kernel, wings ∝ r⁻³), whose OTF is
    exp(−2π a f) and whose encircled energy is 1 − a/√(r² + a²): the size-of-source effect.
-   :class:`TabulatedPSF`: a measured PSF on a grid of cells [m], each cell's value its mean.

A list of PSFs is their convolution (the product of their OTFs).

References
----------
-   Goodman, J. W. (2005). Introduction to Fourier Optics, 3rd ed., §6.3.2 (the diffraction-
    limited OTF of a circular pupil).
-   Born, M. & Wolf, E. (1999). Principles of Optics, 7th ed., §8.5.2 (the Airy pattern and its
    encircled energy 1 − J₀² − J₁²).
-   Saunders, P. (2015). MSL Technical Guide 26: Size-of-source effect (the SSE and its
    measurement with discs of increasing diameter).
-   Stein, E. M. & Weiss, G. (1971). Introduction to Fourier Analysis on Euclidean Spaces,
    ch. I §1 (the Poisson kernel and its Fourier transform exp(−2π a f), f the radial frequency).
"""

from __future__ import annotations

import functools
import math
import warnings
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import fft as sfft

from radiosim.checks import check_count, check_fraction, check_positive
from radiosim.config import edge_value, si_value
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.kernels.engines import get_engine

__all__ = ["PSF", "Diffraction", "GaussianBlur", "ScatterHalo", "TabulatedPSF", "as_psf",
           "psf_floor", "transfer", "sampled_transfer", "blur", "blur_bands", "padded_shape",
           "fft_shape", "padding", "reach", "PAD_ENERGY", "MERGE_TOLERANCE",
           "airy_encircled_energy", "halo_encircled_energy", "PSF_TYPES"]

#: H − floor below this fraction (in magnitude) is negligible: the aliases beyond are not summed.
_NEGLIGIBLE = 1e-13
#: Aliases either side summed in 2-D; a PSF that factorises per axis sums up to the second
#: number in 1-D.
_MAX_ALIASES = 4
_MAX_AXIS_ALIASES = 20000


class PSF(ABC):
    """A point-spread function, described by its OTF in object space."""

    #: The OTF's limit at infinite frequency: the part of the PSF that is a point (1 − β for a
    #: halo, 0 for a PSF with no point-like part).
    floor: float = 0.0
    #: Whether the OTF depends on wavelength (then the blur is polychromatic).
    chromatic: bool = False

    @abstractmethod
    def otf(self, fx: np.ndarray, fy: np.ndarray, wavelength: float, object_na: float):
        """The OTF at object-space frequencies ``fx``, ``fy`` [cycles m⁻¹] (broadcast), for
        ``wavelength`` [m] and the object-side numerical aperture ``object_na`` [1]."""

    @abstractmethod
    def bandwidth(self, wavelength: float, object_na: float) -> float:
        """Frequency [cycles m⁻¹] beyond which the OTF differs from its floor by less than 1e-13
        (the aliases summed)."""

    @abstractmethod
    def reach(self, wavelength: float, object_na: float) -> float:
        """Distance [m] beyond which the PSF's kernel is negligible against its core (20 core
        widths for the power-law wings of the Airy pattern and the halo): the padding of a
        blur."""

    def radius(self, energy: float, wavelength: float, object_na: float) -> float:
        """Radius [m] beyond which less than ``energy`` [1] of the PSF's light lies (its
        encircled energy exceeds 1 − ``energy`` there); by default its :meth:`reach`."""
        return self.reach(wavelength, object_na)

    def to_table(self) -> dict:
        """The PSF as a TOML table (``type`` and its parameters in edge units)."""
        raise RadiosimError(f"{type(self).__name__} cannot be written to a camera file")


@dataclass(frozen=True)
class Diffraction(PSF):
    """
    The Airy pattern of the camera's circular pupil at its working f-number, polychromatic.

    Parameters
    ----------
    sub_bands
        Spectral sub-bands of equal width the band is split into; each sample's radiance is
        computed per sub-band and blurred with the Airy pattern of the sub-band's centre
        wavelength, and the results add (so a hot and a cold source get their own effective
        PSF). One sub-band uses the band's centre for all the light.

    Examples
    --------
    >>> h = Diffraction()
    >>> float(h.otf(np.array(0.0), np.array(0.0), 4.5e-6, 0.2))  # no loss at zero frequency
    1.0
    >>> round(h.bandwidth(4.5e-6, 0.2) * 1e-3, 2)  # cut-off 2 NA / λ [cycles mm⁻¹]
    88.89
    """

    sub_bands: int = 8
    chromatic = True

    def __post_init__(self):
        object.__setattr__(self, "sub_bands", check_count(self.sub_bands, "sub_bands"))

    def otf(self, fx, fy, wavelength, object_na):
        nu = np.hypot(fx, fy) / self.bandwidth(wavelength, object_na)
        nu = np.minimum(nu, 1.0)
        return (2.0 / math.pi) * (np.arccos(nu) - nu * np.sqrt(1.0 - nu * nu))

    def bandwidth(self, wavelength, object_na):
        if not object_na > 0:
            raise RadiosimError("diffraction needs the optics' object-side numerical aperture")
        return 2.0 * object_na / wavelength

    def reach(self, wavelength, object_na):
        return 20 * 0.61 * wavelength / object_na  # 20 Airy radii: the r⁻³ envelope at 1e-4

    def radius(self, energy, wavelength, object_na):
        # 1 − EE = J₀²(v) + J₁²(v) decreases monotonically (its derivative is −2 J₁²/v) and
        # tends to 2/(π v): bisection in v between 0 and twice that asymptote's root.
        if energy >= 1.0:
            return 0.0
        from scipy.special import j0, j1

        lo, hi = 0.0, 4.0 / (math.pi * energy) + 10.0
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            if j0(mid) ** 2 + j1(mid) ** 2 > energy:
                lo = mid
            else:
                hi = mid
        return hi * wavelength / (2 * math.pi * object_na)

    def to_table(self) -> dict:
        return {"type": "diffraction", "sub_bands": self.sub_bands}


@dataclass(frozen=True)
class GaussianBlur(PSF):
    """
    A Gaussian blur of standard deviation ``sigma`` [m, object space] per axis (aberrations,
    defocus, vibration lumped).

    Examples
    --------
    >>> round(float(GaussianBlur(1e-6).otf(np.array(1e5), np.array(0.0), 4e-6, 0.2)), 6)
    0.820869
    """

    sigma: float = 1e-6

    def __post_init__(self):
        object.__setattr__(self, "sigma", check_positive(self.sigma, "GaussianBlur sigma", "m"))

    def otf(self, fx, fy, wavelength, object_na):
        return np.exp(-2.0 * math.pi**2 * self.sigma**2 * (fx * fx + fy * fy))

    def bandwidth(self, wavelength, object_na):
        return math.sqrt(math.log(1 / _NEGLIGIBLE) / 2.0) / (math.pi * self.sigma)

    def reach(self, wavelength, object_na):
        return 8 * self.sigma

    def radius(self, energy, wavelength, object_na):
        # The light beyond r of a circular Gaussian: exp(−r²/2σ²).
        return 0.0 if energy >= 1.0 else self.sigma * math.sqrt(2 * math.log(1 / energy))

    def axis_terms(self, f, axis: int) -> np.ndarray:
        """The OTF per axis as (frequencies, 1) terms (see :func:`sampled_transfer`)."""
        return np.exp(-2.0 * math.pi**2 * self.sigma**2 * f * f)[:, None]

    def to_table(self) -> dict:
        return {"type": "gaussian", "sigma_um": edge_value(self.sigma, 1e-6)}


@dataclass(frozen=True)
class ScatterHalo(PSF):
    """
    A fraction of the light scattered into a wide halo with power-law wings (the size-of-source
    effect of real optics): h = (1 − β)·δ + β·a / (2π (r² + a²)^(3/2)).

    Parameters
    ----------
    fraction
        β, the fraction of the light in the halo [1].
    width
        a, the halo's core radius [m, object space]; half its energy lies within a·√3.

    Examples
    --------
    >>> halo = ScatterHalo(0.05, 100e-6)
    >>> halo.floor, round(float(halo_encircled_energy(100e-6 * math.sqrt(3), 100e-6)), 12)
    (0.95, 0.5)
    """

    fraction: float = 0.02
    width: float = 100e-6

    def __post_init__(self):
        object.__setattr__(self, "fraction", check_fraction(self.fraction, "halo fraction"))
        object.__setattr__(self, "width", check_positive(self.width, "halo width", "m"))

    @property
    def floor(self) -> float:
        return 1.0 - self.fraction

    def otf(self, fx, fy, wavelength, object_na):
        return self.floor + self.fraction * np.exp(-2.0 * math.pi * self.width *
                                                   np.hypot(fx, fy))

    def bandwidth(self, wavelength, object_na):
        return math.log(max(self.fraction, _NEGLIGIBLE) / _NEGLIGIBLE) / (2 * math.pi *
                                                                          self.width)

    def reach(self, wavelength, object_na):
        return 20 * self.width  # the kernel there is 1e-4 of its centre's

    def radius(self, energy, wavelength, object_na):
        # The light beyond r: β a / √(r² + a²) (the point part lies at r = 0).
        if energy >= self.fraction:
            return 0.0
        return self.width * math.sqrt((self.fraction / energy) ** 2 - 1.0)

    def to_table(self) -> dict:
        return {"type": "scatter_halo", "fraction": self.fraction, "width_um": edge_value(self.width, 1e-6)}


@dataclass(frozen=True, eq=False)
class TabulatedPSF(PSF):
    """
    A measured PSF: values on a grid of square cells of side ``pitch`` [m, object space],
    centred on the array's centre; each value is the PSF's mean over its cell. Normalised to
    unit sum on construction.

    Parameters
    ----------
    kernel
        2-D array (rows = y), or the path of a CSV file (comma-separated rows) or of an EXR file
        (its first channel).
    pitch
        Cell size [m, object space].
    """

    kernel: np.ndarray = field(default_factory=lambda: np.ones((1, 1)))
    pitch: float = 1e-6

    def __post_init__(self):
        kernel = self.kernel
        if isinstance(kernel, (str, Path)):
            kernel = _read_kernel(Path(kernel))
        kernel = np.asarray(kernel, dtype=float)
        if kernel.ndim != 2 or kernel.size == 0:
            raise RadiosimError(f"a tabulated PSF must be a 2-D array, got shape {kernel.shape}")
        if not np.all(np.isfinite(kernel)) or np.any(kernel < 0) or not kernel.sum() > 0:
            raise RadiosimError("a tabulated PSF must hold finite values ≥ 0 with a positive sum")
        object.__setattr__(self, "kernel", kernel / kernel.sum())
        object.__setattr__(self, "pitch", check_positive(self.pitch, "PSF pitch", "m"))

    def otf(self, fx, fy, wavelength, object_na):
        ny, nx = self.kernel.shape
        y = (np.arange(ny) - (ny - 1) / 2) * self.pitch
        x = (np.arange(nx) - (nx - 1) / 2) * self.pitch
        fx, fy = np.broadcast_arrays(fx, fy)
        if fx.ndim == 2 and np.all(fx == fx[:1]) and np.all(fy == fy[:, :1]):
            # A grid: the separable DFT, (fy × y) · kernel · (x × fx).
            ey = np.exp(-2j * math.pi * np.outer(fy[:, 0], y))
            ex = np.exp(-2j * math.pi * np.outer(x, fx[0]))
            h = ey @ self.kernel @ ex
        else:
            h = np.einsum("ij,...i,...j->...", self.kernel,
                          np.exp(-2j * math.pi * fy[..., None] * y),
                          np.exp(-2j * math.pi * fx[..., None] * x))
        return h * np.sinc(fx * self.pitch) * np.sinc(fy * self.pitch)

    def bandwidth(self, wavelength, object_na):
        # Cells have sharp edges, so the OTF never vanishes: its sinc envelope 1/(π f pitch)
        # times the aliases' own sinc² (≤ 1/(π k)²) falls below 1e-6 within 30/pitch (not the
        # 1e-13 of the smooth models; the per-axis sum beyond is bounded in _axis_sum).
        return 30.0 / self.pitch

    def reach(self, wavelength, object_na):
        return 0.5 * max(self.kernel.shape) * self.pitch

    def radius(self, energy, wavelength, object_na):
        # Cells whose farthest corner lies beyond r hold all the light beyond r.
        y, x = np.meshgrid(np.abs(self._centres(0)), np.abs(self._centres(1)), indexing="ij")
        far = np.hypot(y + 0.5 * self.pitch, x + 0.5 * self.pitch).ravel()
        order = np.argsort(far)[::-1]
        outside = np.cumsum(self.kernel.ravel()[order])  # light beyond far[order[k + 1]]
        beyond = np.flatnonzero(outside > energy)
        return 0.0 if beyond.size == 0 else float(far[order[beyond[0]]])

    def _centres(self, axis: int) -> np.ndarray:
        n = self.kernel.shape[axis]
        return (np.arange(n) - (n - 1) / 2) * self.pitch

    def axis_terms(self, f, axis: int) -> np.ndarray:
        """Per axis, the transfer of each row (axis 0) or column (axis 1) of cells: a box of
        the pitch at its centre, (frequencies, cells)."""
        return (np.sinc(f * self.pitch)[:, None]
                * np.exp(-2j * math.pi * np.outer(f, self._centres(axis))))

    def to_table(self) -> dict:
        return {"type": "tabulated", "kernel": self.kernel.tolist(),
                "pitch_um": edge_value(self.pitch, 1e-6)}


def _read_kernel(path: Path) -> np.ndarray:
    if not path.is_file():
        raise RadiosimError(f"PSF file {path} does not exist")
    if path.suffix.lower() == ".exr":
        import OpenEXR

        try:
            with OpenEXR.File(str(path)) as exr:
                channels = exr.channels()
                name = sorted(channels)[0]
                return np.array(channels[name].pixels, dtype=float)
        except Exception as exc:  # a broken file: one line naming it
            raise RadiosimError(f"cannot read PSF file {path}: {exc}") from None
    try:
        return np.loadtxt(path, delimiter=",", ndmin=2, comments="#")
    except ValueError as exc:
        raise RadiosimError(f"cannot read PSF file {path} as comma-separated numbers: {exc}") \
            from None


#: PSF models by the ``type`` of their TOML table, with each parameter's key and scale to SI.
PSF_TYPES = {
    "diffraction": (Diffraction, {"sub_bands": ("sub_bands", 1)}),
    "gaussian": (GaussianBlur, {"sigma_um": ("sigma", 1e-6)}),
    "scatter_halo": (ScatterHalo, {"fraction": ("fraction", 1), "width_um": ("width", 1e-6)}),
    "tabulated": (TabulatedPSF, {"file": ("kernel", None), "kernel": ("kernel", "inline"),
                                 "pitch_um": ("pitch", 1e-6)}),
}


def as_psf(value, base: Path | None = None) -> tuple[PSF, ...] | None:
    """
    PSFs from Python objects or TOML tables: ``None``, a :class:`PSF`, a table
    ``{type = "diffraction", ...}`` or a list of either; returned as a tuple (their
    convolution), or ``None`` for a perfect lens.
    """
    if value is None:
        return None
    items = value if isinstance(value, (list, tuple)) else [value]
    out = []
    for item in items:
        if isinstance(item, PSF):
            out.append(item)
            continue
        if not isinstance(item, dict) or "type" not in item:
            raise RadiosimError(f"a PSF must be a PSF object or a table with a type "
                                f"({', '.join(PSF_TYPES)}), got {item!r}")
        kind = item["type"]
        if kind not in PSF_TYPES:
            raise RadiosimError(f"unknown PSF type {kind!r}; expected one of "
                                f"{', '.join(PSF_TYPES)}")
        cls, keys = PSF_TYPES[kind]
        unknown = set(item) - set(keys) - {"type"}
        if unknown:
            raise RadiosimError(f"PSF {kind!r} has unknown keys {sorted(unknown)}; expected "
                                f"{sorted(keys)}")
        kwargs = {}
        for key, (name, scale) in keys.items():
            if key in item:
                raw = item[key]
                if scale is None:  # a file path, relative to the camera file
                    raw = Path(raw) if base is None else base / raw
                elif scale == "inline":  # the values themselves (rows of numbers)
                    raw = np.asarray(raw, dtype=float)
                elif isinstance(raw, bool) or not isinstance(raw, (int, float)):
                    raise RadiosimError(f"PSF {kind!r}: {key} must be a number, got {raw!r}")
                else:
                    raw = si_value(raw, scale) if scale != 1 else raw
                kwargs[name] = raw
        out.append(cls(**kwargs))
    return tuple(out) or None


def psf_floor(psfs) -> float:
    """The point-like fraction of a convolution of PSFs (the product of their floors)."""
    return math.prod(p.floor for p in psfs)


def transfer(psfs, fx, fy, wavelength: float, object_na: float):
    """The OTF of a convolution of PSFs (the product of theirs)."""
    out = 1.0
    for p in psfs:
        out = out * p.otf(fx, fy, wavelength, object_na)
    return out


def _bandwidth(psfs, wavelength, object_na) -> float:
    """Frequency beyond which the product OTF differs from its floor by < 1e-13."""
    pointless = [p.bandwidth(wavelength, object_na) for p in psfs if p.floor == 0]
    if pointless:
        return min(pointless)
    return max(p.bandwidth(wavelength, object_na) for p in psfs)


def _aliases(frequencies: np.ndarray, dx: float, bandwidth: float) -> list[int]:
    """The aliases k for which some shifted frequency f + k/dx lies within the bandwidth (at
    most ±4)."""
    nyquist = 0.5 / dx
    out = []
    for k in range(-_MAX_ALIASES, _MAX_ALIASES + 1):
        if abs(k) / dx - nyquist <= bandwidth * (1 + 1e-12):
            out.append(k)
    return out


def _axis_sum(psf, f: np.ndarray, dx: float, bandwidth: float, axis: int) -> np.ndarray:
    """Σ_k sinc²((f + k/dx)·dx) · terms(f + k/dx) over every alias within the bandwidth, for
    a PSF whose OTF factorises per axis (frequencies, terms)."""
    # Beyond alias n the weights sinc² ≤ 1/(π k)² leave at most 2/(π² n) of a unit transfer:
    # 1e-5 at the cap, for a PSF far narrower than a sample.
    n = min(math.ceil(bandwidth * dx + 0.5), _MAX_AXIS_ALIASES)
    out = 0.0
    for k in range(-n, n + 1):
        g = f + k / dx
        out = out + (np.sinc(g * dx) ** 2)[:, None] * psf.axis_terms(g, axis)
    return out


def _separable(psfs) -> PSF | None:
    """The PSF whose OTF factorises per axis that the list amounts to, if any: a tabulated PSF
    alone, or Gaussians (one Gaussian of the summed variances)."""
    if len(psfs) == 1 and hasattr(psfs[0], "axis_terms"):
        return psfs[0]
    if all(isinstance(p, GaussianBlur) for p in psfs):
        return GaussianBlur(math.sqrt(sum(p.sigma**2 for p in psfs)))
    return None


def sampled_transfer(psfs, shape: tuple[int, int], dx: float, wavelength: float,
                     object_na: float) -> np.ndarray:
    """
    The transfer function K̂ of the sample-square averages of the blurred field, on the real-
    FFT grid of ``shape`` (rows, columns) [1] (see the module docstring).

    Examples
    --------
    >>> k = sampled_transfer([ScatterHalo(0.1, 20e-6)], (64, 64), 1e-6, 4e-6, 0.2)
    >>> float(k[0, 0].real)  # a uniform field is unchanged
    1.0
    """
    return _transfer_on(psfs, sfft.fftfreq(shape[0], dx), sfft.rfftfreq(shape[1], dx), dx,
                        wavelength, object_na)


def _transfer_on(psfs, fy: np.ndarray, fx: np.ndarray, dx: float, wavelength: float,
                 object_na: float) -> np.ndarray:
    """K̂ at the row frequencies ``fy`` × column frequencies ``fx`` [cycles m⁻¹]."""
    bandwidth = _bandwidth(psfs, wavelength, object_na)
    separable = _separable(psfs)
    if separable is not None:  # Σ over (ky, kx) = (Σ over ky) ⊗ (Σ over kx), per term
        rows = _axis_sum(separable, fy, dx, bandwidth, 0)
        cols = _axis_sum(separable, fx, dx, bandwidth, 1)
        if isinstance(separable, TabulatedPSF):
            return rows @ separable.kernel @ cols.T
        return rows @ cols.T
    if bandwidth * dx > _MAX_ALIASES + 0.5:
        warnings.warn(f"the PSF's transfer reaches {bandwidth * dx:.3g} / dx, beyond the "
                      f"±{_MAX_ALIASES} aliases summed: its blur of {dx:.3g} m samples is "
                      "approximate (sample the scene finer)", RadiosimWarning, stacklevel=4)
    floor = psf_floor(psfs)
    fy, fx = fy[:, None], fx[None, :]
    out = np.full((fy.size, fx.size), floor, dtype=complex)
    for ky in _aliases(fy, dx, bandwidth):
        gy = fy + ky / dx
        sy = np.sinc(gy * dx) ** 2
        for kx in _aliases(fx, dx, bandwidth):
            gx = fx + kx / dx
            sx = np.sinc(gx * dx) ** 2
            out += sy * sx * (transfer(psfs, gx, gy, wavelength, object_na) - floor)
    return out


#: A blur's padding leaves less than this fraction of the PSF's light beyond it (see
#: :func:`padding`): the error of the circular convolution, per unit of the field's contrast.
PAD_ENERGY = 5e-3
#: The padding of an axis is at most this many times the field's length.
_MAX_PAD = 4
#: Sub-bands whose sampled kernels differ by at most this L1 norm [1] share one transfer
#: (:func:`blur_bands`).
MERGE_TOLERANCE = 1e-9


def padding(psfs, wavelength: float, object_na: float, energy: float = PAD_ENERGY) -> float:
    """
    The padding [m] of a blur: the distance beyond which less than ``energy`` [1] of the light
    of the convolution of ``psfs`` lies, Σᵢ rᵢ with rᵢ each PSF's :meth:`~PSF.radius` at
    ``energy`` / n (a point displaced by more than Σ rᵢ has at least one of its n PSFs'
    displacements beyond its rᵢ: the union bound).
    """
    psfs = list(psfs)
    share = energy / max(len(psfs), 1)
    return sum(p.radius(share, wavelength, object_na) for p in psfs)


#: A blur pads each axis of n samples by n to 3n samples of surroundings (the former rule,
#: :func:`padded_shape`).
_PAD_RANGE = (1, 3)


def padded_shape(shape: tuple[int, int], reach: float = 0.0) -> tuple[int, int]:
    """
    The FFT grid of a field of ``shape`` samples padded by ``reach`` [samples]: each axis
    padded by the reach, at least the field's length and at most three times it, rounded up
    to a fast length (the former rule of :func:`blur`, kept for callers;
    :func:`blur` pads by :func:`padding` instead).
    """
    low, high = _PAD_RANGE
    return tuple(sfft.next_fast_len(n + int(min(max(low * n, math.ceil(reach)), high * n)),
                                    real=True) for n in shape)


def fft_shape(shape: tuple[int, int], pad: float) -> tuple[int, int]:
    """The FFT grid of a blur of a field of ``shape`` samples with ``pad`` [samples] of
    surroundings between its periodic copies (at most :data:`_MAX_PAD` field lengths, plus
    two samples for the sample squares' own width), each axis rounded up to a fast length."""
    return tuple(sfft.next_fast_len(n + int(min(math.ceil(pad) + 2, _MAX_PAD * n)), real=True)
                 for n in shape)


def reach(psfs, wavelength: float, object_na: float) -> float:
    """The reach [m] of a convolution of PSFs: the sum of theirs."""
    return sum(p.reach(wavelength, object_na) for p in psfs)


def _support(psfs, n: int, dx: float, bandwidth: float, real: bool) -> np.ndarray:
    """The frequency indices of an axis of ``n`` samples (real FFT: the non-negative ones)
    where the sampled transfer of ``psfs`` may differ from 0: all, unless the product OTF has
    no point-like part and vanishes beyond ``bandwidth`` below Nyquist (then no alias reaches
    the axis and K̂ = 0 beyond the bandwidth)."""
    f = sfft.rfftfreq(n, dx) if real else sfft.fftfreq(n, dx)
    if psf_floor(psfs) != 0.0 or bandwidth * dx >= 0.5:
        return np.arange(f.size)
    return np.flatnonzero(np.abs(f) <= bandwidth * (1 + 1e-12))


#: The transfers :func:`_cached_transfer` keeps, at most this many bytes (the oldest go first).
TRANSFER_CACHE_BYTES = 256 * 2**20
_TRANSFERS: dict = {}


def _cached_transfer(psfs: tuple, shape: tuple[int, int], dx: float, wavelength: float,
                     object_na: float):
    """K̂ of ``psfs`` on the real-FFT grid of ``shape`` where it may differ from 0: (row
    indices, column count, K̂ there), read-only; cached per PSFs, grid, wavelength and NA
    (at most :data:`TRANSFER_CACHE_BYTES`)."""
    key = (psfs, tuple(shape), float(dx), float(wavelength), float(object_na))
    found = _TRANSFERS.pop(key, None)
    if found is None:
        found = _transfer_support(*key)
        size = found[2].nbytes
        while _TRANSFERS and sum(v[2].nbytes for v in _TRANSFERS.values()) + size \
                > TRANSFER_CACHE_BYTES:
            _TRANSFERS.pop(next(iter(_TRANSFERS)))
    _TRANSFERS[key] = found  # the most recent last
    return found


def _transfer_support(psfs: tuple, shape: tuple[int, int], dx: float, wavelength: float,
                      object_na: float):
    """:func:`_cached_transfer`, computed."""
    bandwidth = _bandwidth(psfs, wavelength, object_na)
    rows = _support(psfs, shape[0], dx, bandwidth, False)
    cols = _support(psfs, shape[1], dx, bandwidth, True)
    n_cols = int(cols[-1]) + 1
    k = _transfer_on(psfs, sfft.fftfreq(shape[0], dx)[rows], sfft.rfftfreq(shape[1], dx)[:n_cols],
                     dx, wavelength, object_na)
    rows.flags.writeable = False
    k.flags.writeable = False
    return rows, n_cols, k


def _kernel_distance(a, b, shape) -> float:
    """‖k_a − k_b‖₁: the L1 norm of the difference of two sampled kernels, from their
    transfers (:func:`_cached_transfer`) on the grid of ``shape``."""
    diff = np.zeros((shape[0], shape[1] // 2 + 1), dtype=complex)
    diff[a[0], :a[1]] += a[2]
    diff[b[0], :b[1]] -= b[2]
    return float(np.abs(sfft.irfft2(diff, shape, workers=-1)).sum())


def _transfer_gap(a, b) -> float:
    """max |K̂_a − K̂_b| over the frequencies both supports hold: a lower bound of
    ‖k_a − k_b‖₁ (|Σ Δk e^{…}| ≤ Σ |Δk|)."""
    rows, ia, ib = np.intersect1d(a[0], b[0], return_indices=True)
    n = min(a[1], b[1])
    if rows.size == 0 or n == 0:
        return 0.0
    return float(np.abs(a[2][ia, :n] - b[2][ib, :n]).max())


@functools.lru_cache(maxsize=16)
def _merged_bands(psfs: tuple, shape: tuple[int, int], dx: float, wavelengths: tuple,
                  object_na: float, tolerance: float) -> tuple:
    """The sub-bands grouped by transfer: each group (its first sub-band, the members) with
    ‖k_first − k_member‖₁ ≤ ``tolerance`` (cached per PSFs, grid and wavelengths)."""
    transfers = [_cached_transfer(psfs, shape, dx, w, object_na) for w in wavelengths]
    groups: list[tuple[int, list[int]]] = []
    for b, t in enumerate(transfers):
        for first, members in groups:
            u = transfers[first]
            same = (u[1] == t[1] and np.array_equal(u[0], t[0]) and np.array_equal(u[2], t[2]))
            if same or (tolerance > 0 and _transfer_gap(u, t) <= tolerance
                        and _kernel_distance(u, t, shape) <= tolerance):
                members.append(b)
                break
        else:
            groups.append((b, [b]))
    return tuple((first, tuple(members)) for first, members in groups)


def blur(field: np.ndarray, surroundings: float, psfs, dx: float, wavelength: float,
         object_na: float, engine=None) -> np.ndarray:
    """
    The sample-square averages of a sampled radiance field seen through the PSFs.

    Parameters
    ----------
    field
        Radiance per sample (any unit), 2-D; sample pitch ``dx`` [m].
    surroundings
        Radiance of everything outside the field (same unit): light from there enters through
        the PSF's wings.
    psfs
        The PSFs (their convolution).
    dx
        Sample pitch [m, object space].
    wavelength
        Wavelength of the light [m] (for chromatic PSFs).
    object_na, engine
        As for :func:`blur_bands`.

    Returns
    -------
    numpy.ndarray
        Blurred field, shaped like ``field``.

    Notes
    -----
    :func:`blur_bands` of one band (its notes: the padding and its error bound).
    """
    return blur_bands([field], [surroundings], psfs, dx, [wavelength], object_na, engine=engine)


def blur_bands(fields, surroundings, psfs, dx: float, wavelengths, object_na: float,
               energy: float = PAD_ENERGY, tolerance: float = MERGE_TOLERANCE,
               engine=None) -> np.ndarray:
    """
    Σ_b of the sample-square averages of sub-band b's radiance field seen through the PSFs at
    its wavelength: the blurred image of several sub-bands, in one inverse transform.

    Parameters
    ----------
    fields
        Radiance per sample of each sub-band (any unit), 2-D, one shape; pitch ``dx`` [m].
    surroundings
        Each sub-band's radiance outside the field (same unit).
    psfs
        The PSFs (their convolution).
    dx
        Sample pitch [m, object space].
    wavelengths
        Each sub-band's wavelength [m].
    object_na
        Object-side numerical aperture of the working cone [1].
    energy
        The light [1] the padding may leave beyond it (:func:`padding`).
    tolerance
        Sub-bands whose sampled kernels differ by at most this L1 norm share a transfer.
    engine
        The engine whose ``fft`` transforms (a name, an Engine or ``None``: the chosen one).

    Returns
    -------
    numpy.ndarray
        The blurred sum, shaped like a field.

    Notes
    -----
    Each field less its surroundings is placed on a grid of :func:`fft_shape` (zeros around
    it) and convolved circularly: each sample also receives the light of the field's periodic
    copies instead of the surroundings'. Those copies lie beyond the padding P (:func:`padding`
    at the longest wavelength) from every sample of the field, so the error at any sample is at
    most ``energy`` × max abs(field − surroundings) per sub-band (the light beyond P), or the
    light beyond :data:`_MAX_PAD` field lengths where the padding is capped there.

    The transforms take only the frequencies where the transfer can differ from 0: a PSF with
    no point-like part whose OTF vanishes beyond a frequency below Nyquist (diffraction) needs
    the columns and rows below that frequency, so the forward transform runs over the field's
    rows and those columns, the inverse over those columns and the field's rows (the same
    discrete Fourier transform, to rounding). Transfers are cached per PSFs, grid and
    wavelength; the spectra of all sub-bands add before one inverse transform (the blur is
    linear), and sub-bands whose kernels differ by at most ``tolerance`` in L1 norm are added
    before one forward transform: their error is at most ``tolerance`` × max abs(field −
    surroundings) of each sub-band so merged.
    """
    fft = get_engine(engine).fft
    fields = [np.asarray(f, dtype=float) for f in fields]
    n_rows, n_cols = fields[0].shape
    psfs = tuple(psfs)  # hashable: the transfers are cached per PSFs
    wavelengths = tuple(float(w) for w in wavelengths)
    pad = max(padding(psfs, w, object_na, energy) for w in wavelengths) / dx
    shape = fft_shape((n_rows, n_cols), pad)
    groups = _merged_bands(psfs, shape, dx, wavelengths, object_na, float(tolerance))
    transfers = [_cached_transfer(psfs, shape, dx, wavelengths[first], object_na)
                 for first, _ in groups]
    rows = functools.reduce(np.union1d, [t[0] for t in transfers])  # the union of supports
    n_freq = max(t[1] for t in transfers)
    spectrum = np.zeros((rows.size, n_freq), dtype=complex)
    # The field less its surroundings, zero-padded to the transform's length once: each
    # sub-band (group) writes its own part, the padding stays zero (the same transform as
    # rfft(g, n), without a padded copy per sub-band).
    padded = np.zeros((n_rows, shape[1]))
    g = padded[:, :n_cols]
    for (first, members), (band_rows, band_freq, k) in zip(groups, transfers):
        np.subtract(fields[members[0]], float(surroundings[members[0]]), out=g)
        for b in members[1:]:
            g += fields[b] - float(surroundings[b])
        part = fft.rfft(padded, axis=1, workers=-1)[:, :band_freq]
        part = fft.fft(part, shape[0], axis=0, workers=-1)[band_rows]
        part *= k
        if band_rows.size == rows.size and band_freq == n_freq:
            spectrum += part
        else:
            spectrum[np.searchsorted(rows, band_rows), :band_freq] += part
    full = np.zeros((shape[0], n_freq), dtype=complex)
    full[rows] = spectrum
    part = fft.ifft(full, axis=0, workers=-1)[:n_rows]
    out = np.zeros((n_rows, shape[1] // 2 + 1), dtype=complex)
    out[:, :n_freq] = part
    result = fft.irfft(out, shape[1], axis=1, workers=-1)[:, :n_cols]
    return result + float(sum(float(s) for s in surroundings))


def airy_encircled_energy(radius, wavelength: float, object_na: float):
    """
    Fraction of an Airy pattern's energy within ``radius`` [m, object space]:
    1 − J₀²(v) − J₁²(v), v = 2π NA r / λ (Born & Wolf §8.5.2).

    Examples
    --------
    >>> round(float(airy_encircled_energy(0.61 * 4e-6 / 0.2, 4e-6, 0.2)), 3)  # first dark ring
    0.838
    """
    from scipy.special import j0, j1

    v = 2 * math.pi * object_na * np.asarray(radius, dtype=float) / wavelength
    return 1.0 - j0(v) ** 2 - j1(v) ** 2


def halo_encircled_energy(radius, width: float):
    """Fraction of a :class:`ScatterHalo`'s halo within ``radius`` [m]: 1 − a/√(r² + a²)."""
    r = np.asarray(radius, dtype=float)
    return 1.0 - width / np.sqrt(r * r + width * width)

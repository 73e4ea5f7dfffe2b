"""
Focal-plane-array electronics: charge, noise, full well and analogue-to-digital conversion.

The model is the EMVA 1288 linear camera: the mean digital signal is
μ_y = μ_y,dark + K μ_e with μ_e the mean photo-electrons, and its variance
σ²_y = K² (σ²_d + σ²_e) + σ²_q with σ²_e = μ_e (Poisson shot noise), σ_d the read noise and
σ²_q = 1/12 DN² the quantisation noise; hence the photon-transfer relation
σ²_y − σ²_y,dark = K (μ_y − μ_y,dark) below saturation.

Each effect is one pure function; :meth:`Electronics.expose` applies them in physical order.
Randomness comes only from an explicit ``rng``.

Two departures from the linear model are optional (off by default, when the chain is the
linear one bit for bit):

-   the array's fixed pattern (:class:`~radiosim.fpa.FixedPattern`: PRNU on the photo-charge,
    DSNU on the dark charge, dead and hot pixels), passed to :meth:`Electronics.expose`;
-   non-linearity: the charge-to-signal conversion bends toward full well,
    e_out = e · (1 − β · e / FW) (a quadratic compression; β is the relative loss of signal
    at full well, the electronics' ``nonlinearity``, times the pixel's own factor), the form
    of the EMVA 1288 linearity-error measurement's deviation. The calibration inverts it
    (:meth:`Electronics.photoelectrons`).

References
----------
-   EMVA Standard 1288, Release 4.0 Linear (2021): Standard for characterization of image
    sensors and cameras. European Machine Vision Association.
-   Janesick, J. R. (2007). Photon Transfer, DN → λ. SPIE Press.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radiosim.checks import check_rng
from radiosim.config import edge_field
from radiosim.errors import RadiosimError

__all__ = [
    "add_dark_charge",
    "apply_shot_noise",
    "clip_full_well",
    "apply_read_noise",
    "apply_nonlinearity",
    "invert_nonlinearity",
    "analogue_counts",
    "quantise",
    "Electronics",
    "Exposure",
]


def add_dark_charge(electrons: np.ndarray, dark_current: float, integration_time: float):
    """Mean charge plus dark charge [e⁻]: dark current [e⁻/s] × integration time [s]."""
    return electrons + dark_current * integration_time


def apply_shot_noise(electrons: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A Poisson draw of the collected charge [e⁻] around its mean [e⁻] (σ² = μ)."""
    return rng.poisson(np.clip(electrons, 0.0, None)).astype(np.float64)


def clip_full_well(electrons: np.ndarray, full_well: float | None):
    """
    Collected charge limited by the well capacity [e⁻].

    Returns the clipped charge and the boolean mask of full wells.
    """
    if full_well is None:
        return electrons, np.zeros(np.shape(electrons), dtype=bool)
    full = electrons >= full_well
    return np.minimum(electrons, full_well), full


def apply_read_noise(electrons: np.ndarray, read_noise: float, rng: np.random.Generator):
    """Charge plus zero-mean Gaussian read noise of ``read_noise`` e⁻ rms [e⁻]."""
    if read_noise == 0:
        return electrons
    return electrons + rng.normal(0.0, read_noise, np.shape(electrons))


def apply_nonlinearity(electrons, nonlinearity, full_well: float | None):
    """
    The conversion's compression of charge [e⁻] into signal [e⁻ equivalent]:
    e · (1 − β · e / FW), β = ``nonlinearity`` (a scalar or a per-pixel map) [1].

    Examples
    --------
    >>> float(apply_nonlinearity(1e6, 0.05, 1e6))  # 5 % signal lost at full well
    950000.0
    """
    if full_well is None or np.all(np.asarray(nonlinearity) == 0):
        return electrons
    # Past the parabola's top, FW/(2β) (beyond the well), the curve stays at its top: it never
    # turns down (only unclipped forward models reach there).
    top = full_well / (2.0 * np.maximum(nonlinearity, 1e-300))
    electrons = np.minimum(electrons, top)
    return electrons * (1.0 - nonlinearity * electrons / full_well)


def invert_nonlinearity(signal, nonlinearity: float, full_well: float | None):
    """
    The charge [e⁻] of a signal [e⁻ equivalent] (the inverse of :func:`apply_nonlinearity` on
    its rising branch; signals above its top, FW / (4β), have none: NaN).

    Examples
    --------
    >>> float(invert_nonlinearity(apply_nonlinearity(7e5, 0.05, 1e6), 0.05, 1e6))
    700000.0
    """
    if full_well is None or nonlinearity == 0:
        return signal
    signal = np.asarray(signal, dtype=float)
    root = 1.0 - 4.0 * nonlinearity * signal / full_well
    with np.errstate(invalid="ignore"):
        # e = 2y / (1 + √(1 − 4βy/FW)): the stable form of the quadratic's smaller root.
        return np.where(root >= 0, 2.0 * signal / (1.0 + np.sqrt(np.clip(root, 0.0, None))),
                        np.nan)


def analogue_counts(electrons, gain: float, offset: float):
    """The converter's input in digital numbers [DN]: K·e⁻ + offset (no rounding, no clip)."""
    return gain * electrons + offset


def quantise(electrons: np.ndarray, gain: float, offset: float, bits: int | None):
    """
    Digital numbers: DN = round(K·e⁻ + offset), clipped to [0, 2^bits − 1].

    With ``bits=None`` the converter is ideal: no rounding, no clipping.

    Returns
    -------
    counts : numpy.ndarray
        Digital numbers [DN] (float64 holding integers when ``bits`` is set).
    low, high : numpy.ndarray of bool
        Pixels clipped at 0 and at 2^bits − 1.
    """
    analogue = analogue_counts(electrons, gain, offset)  # [DN]
    if bits is None:
        none = np.zeros(np.shape(analogue), dtype=bool)
        return analogue, none, none
    top = float(2**bits - 1)
    counts = np.clip(np.rint(analogue), 0.0, top)
    return counts, counts <= 0.0, counts >= top


@dataclass(frozen=True)
class Exposure:
    """
    The read-out of one integration.

    Attributes
    ----------
    electrons : numpy.ndarray
        Charge in the well at the end of integration, after the full-well clip [e⁻].
    counts : numpy.ndarray
        Digital numbers [DN].
    saturated : numpy.ndarray of bool
        Full well or converter at its top code.
    adc_floor : numpy.ndarray of bool
        Converter at code 0.
    """

    electrons: np.ndarray
    counts: np.ndarray
    saturated: np.ndarray
    adc_floor: np.ndarray


@dataclass(frozen=True)
class Electronics:
    """
    The pixel's charge-to-counts chain (EMVA 1288 linear model).

    Attributes
    ----------
    full_well : float or None
        Well capacity [e⁻]; ``None``: no saturation.
    dark_current : float
        Dark current [e⁻/s].
    read_noise : float
        Read noise [e⁻ rms].
    shot_noise : bool
        Draw the collected charge from a Poisson distribution.
    gain : float
        System gain K [DN/e⁻].
    offset : float
        Dark offset [DN].
    adc_bits : int or None
        Converter resolution [bit]; ``None``: no quantisation and no clipping.
    nonlinearity : float
        β, the relative signal lost at full well by the conversion's compression [1] (0: the
        linear model); needs a full well.
    """

    full_well: float | None = edge_field(None, "full_well_e", doc="well capacity [e⁻]")
    dark_current: float = edge_field(0.0, "dark_current_e_per_s", doc="dark current [e⁻/s]")
    read_noise: float = edge_field(0.0, "read_noise_e", doc="read noise [e⁻ rms]")
    shot_noise: bool = edge_field(True, "shot_noise", kind="bool", doc="Poisson shot noise")
    gain: float = edge_field(1.0, "gain_dn_per_e", doc="system gain K [DN/e⁻]")
    offset: float = edge_field(0.0, "offset_dn", doc="dark offset [DN]")
    adc_bits: int | None = edge_field(None, "adc_bits", kind="int", doc="ADC resolution [bit]")
    nonlinearity: float = edge_field(0.0, "nonlinearity",
                                     doc="relative signal lost at full well [1]")

    def __post_init__(self):
        checks = [
            (self.full_well is None or (math.isfinite(self.full_well) and self.full_well > 0),
             f"full_well must be None or > 0 [e⁻], got {self.full_well!r}"),
            (math.isfinite(self.dark_current) and self.dark_current >= 0,
             f"dark_current must be ≥ 0 [e⁻/s], got {self.dark_current!r}"),
            (math.isfinite(self.read_noise) and self.read_noise >= 0,
             f"read_noise must be ≥ 0 [e⁻], got {self.read_noise!r}"),
            (math.isfinite(self.gain) and self.gain > 0,
             f"gain must be > 0 [DN/e⁻], got {self.gain!r}"),
            (math.isfinite(self.offset), f"offset must be finite [DN], got {self.offset!r}"),
            (self.adc_bits is None or (int(self.adc_bits) == self.adc_bits
                                        and 1 <= self.adc_bits <= 32),
             f"adc_bits must be None or an integer from 1 to 32, got {self.adc_bits!r}"),
            (math.isfinite(self.nonlinearity) and 0 <= self.nonlinearity < 0.5,
             f"nonlinearity must be in [0, 0.5) (monotonic up to full well), got "
             f"{self.nonlinearity!r}"),
            (self.nonlinearity == 0 or self.full_well is not None,
             "a non-linearity bends toward full well: give full_well too"),
        ]
        for ok, message in checks:
            if not ok:
                raise RadiosimError(message)

    @classmethod
    def ideal(cls) -> Electronics:
        """Noise-free, unsaturable, unquantised electronics with K = 1 DN/e⁻."""
        return cls(shot_noise=False)

    @property
    def is_noise_free(self) -> bool:
        return not self.shot_noise and self.read_noise == 0

    def temporal_noise(self, electrons) -> np.ndarray:
        """
        Temporal noise of a reading [e⁻ rms] for a mean charge ``electrons`` [e⁻] (signal and
        dark): √(μ_e + (σ_read² + 1/(12 K²)) / c'²) — shot noise (if on), read noise and the
        converter's 1/12 DN² quantisation noise referred to the input through the
        conversion's slope c' = 1 − 2β·μ_e/FW (1 for a linear conversion).
        """
        quantisation = 1 / 12 / self.gain**2 if self.adc_bits is not None else 0.0
        charge = np.asarray(electrons, dtype=float)
        shot = charge if self.shot_noise else 0.0
        after = self.read_noise**2 + quantisation  # [e⁻ eq.²] added after the conversion
        if self.nonlinearity and self.full_well is not None:
            # Referred back to charge through the conversion's slope c' = 1 − 2βe/FW.
            after = after / (1.0 - 2.0 * self.nonlinearity * charge / self.full_well) ** 2
        return np.sqrt(shot + after)

    def temporal_noise_counts(self, electrons) -> np.ndarray:
        """
        Temporal noise of a reading [DN rms] for a mean charge ``electrons`` [e⁻] (signal and
        dark): the EMVA 1288 σ_y = √(K² (c'² μ_e + σ_read²) + σ_q²), σ_q² = 1/12 DN² with a
        quantising converter, c' the conversion's slope (1 when linear).

        Examples
        --------
        >>> el = Electronics(read_noise=3.0, gain=0.5, adc_bits=12)
        >>> round(float(el.temporal_noise_counts(16.0)), 12)  # √(0.25·(16 + 9) + 1/12)
        2.516611478424
        """
        charge = np.asarray(electrons, dtype=float)
        slope = 1.0
        if self.nonlinearity and self.full_well is not None:
            slope = 1.0 - 2.0 * self.nonlinearity * charge / self.full_well
        shot = charge if self.shot_noise else 0.0
        quantisation = 1 / 12 if self.adc_bits is not None else 0.0  # [DN²]
        return np.sqrt(self.gain**2 * (slope**2 * shot + self.read_noise**2) + quantisation)

    def mean_counts(self, photoelectrons, integration_time: float) -> np.ndarray:
        """
        Noise-free, unrounded, unclipped digital numbers [DN] of a mean photo-charge [e⁻]:
        the same dark charge and conversion that :meth:`expose` applies, without noise,
        well or converter limits (the calibration's forward model).
        """
        electrons = add_dark_charge(np.asarray(photoelectrons, dtype=float), self.dark_current,
                                    integration_time)  # [e⁻]
        signal = apply_nonlinearity(electrons, self.nonlinearity, self.full_well)  # [e⁻ eq.]
        return analogue_counts(signal, self.gain, self.offset)  # [DN]

    def photoelectrons(self, counts, integration_time: float) -> np.ndarray:
        """The inverse of :meth:`mean_counts`: mean photo-charge [e⁻] of ``counts`` [DN]."""
        signal = (np.asarray(counts, dtype=float) - self.offset) / self.gain  # [e⁻ eq.]
        electrons = invert_nonlinearity(signal, self.nonlinearity, self.full_well)  # [e⁻]
        return electrons - self.dark_current * integration_time

    @property
    def saturation_charge(self) -> float:
        """
        Charge [e⁻] (photo plus dark) at which a pixel saturates: the full well or the
        converter's top code, whichever comes first (∞ if neither).
        """
        limits = [math.inf]
        if self.full_well is not None:
            limits.append(self.full_well)
        if self.adc_bits is not None:
            top = (self.max_count - 0.5 - self.offset) / self.gain  # [e⁻ eq.]
            limits.append(float(invert_nonlinearity(top, self.nonlinearity, self.full_well)))
        return min(v for v in limits if not math.isnan(v))

    @property
    def max_count(self) -> float:
        """Top code of the converter [DN] (∞ without quantisation)."""
        return math.inf if self.adc_bits is None else float(2**self.adc_bits - 1)

    def expose(self, photoelectrons: np.ndarray, integration_time: float,
               rng=None, pattern=None) -> Exposure:
        """
        Turn mean photo-electrons into a noisy, clipped, quantised read-out.

        Parameters
        ----------
        photoelectrons
            Mean photo-generated charge per pixel over the integration [e⁻].
        integration_time
            Integration time [s] (for the dark charge).
        rng
            Seed or :class:`numpy.random.Generator` for shot and read noise.
        pattern
            The array's :class:`~radiosim.fpa.FixedPattern` (shaped like ``photoelectrons``),
            or ``None`` for identical pixels.
        """
        rng = check_rng(rng)
        if pattern is not None:  # PRNU: each pixel's photo-response; dead pixels have none
            photoelectrons = np.where(pattern.dead, 0.0, photoelectrons * pattern.gain)  # [e⁻]
        electrons = add_dark_charge(photoelectrons, self.dark_current, integration_time)  # [e⁻]
        if self.shot_noise:
            electrons = apply_shot_noise(electrons, rng)  # [e⁻], Poisson
        if pattern is not None:  # DSNU: each pixel's dark offset (the readout's, no shot noise)
            electrons = electrons + pattern.dark  # [e⁻ eq.]
        if pattern is not None and pattern.hot.any():  # hot pixels: a stuck, full well
            well = self.full_well if self.full_well is not None else np.inf
            electrons = np.where(pattern.hot, well, electrons)  # [e⁻]
        electrons, full = clip_full_well(electrons, self.full_well)  # [e⁻] in the well
        if pattern is not None:
            full = full | pattern.hot
        beta = (self.nonlinearity if pattern is None
                else self.nonlinearity * pattern.nonlinearity)
        signal = apply_nonlinearity(electrons, beta, self.full_well)  # [e⁻ eq.], compressed
        read = apply_read_noise(signal, self.read_noise, rng)  # [e⁻ eq.] at the converter
        counts, floor, top = quantise(read, self.gain, self.offset, self.adc_bits)  # [DN]
        return Exposure(electrons=electrons, counts=counts, saturated=full | top,
                        adc_floor=floor)

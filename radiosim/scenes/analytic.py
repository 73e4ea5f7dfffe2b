"""
Analytic scenes with closed-form expectations, for tests, teaching and demonstrations.

Each frame is the field evaluated at the frame's mid-time (k + ½)·dt and at sample centres
((j + ½)·dx, (i + ½)·dx): the midpoint rule, so frame averages converge to the continuous time
and area averages as dt and dx shrink.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erf

from radiosim.errors import RadiosimError
from radiosim.scenes.base import Region, Scene, check_emissivity, check_grid, check_positive
from radiosim.units import AMBIENT_TEMPERATURE

__all__ = ["UniformBlackbody", "MovingGaussianBand", "StepEdge"]


def _shape(shape) -> tuple[int, int]:
    try:
        rows, cols = (int(v) for v in shape)
    except (TypeError, ValueError):
        raise RadiosimError(f"shape must be (rows, columns), got {shape!r}") from None
    if rows < 1 or cols < 1:
        raise RadiosimError(f"shape must have at least one row and column, got {shape!r}")
    return rows, cols


class UniformBlackbody(Scene):
    """
    A uniform surface at one temperature: the calibration source.

    Parameters
    ----------
    temperature
        Temperature [K], > 0.
    shape
        Frame shape (rows, columns).
    dx, dt
        Sample pitch [m] and frame interval [s].
    emissivity
        Grey scalar or spectral curve (1: a blackbody).
    n_frames
        Number of frames, or ``None`` for all times.

    Examples
    --------
    >>> scene = UniformBlackbody(1000.0, shape=(18, 18), dx=1e-6, dt=1e-6)
    >>> float(scene.frame(3).mean())
    1000.0
    """

    def __init__(self, temperature, shape=(64, 64), dx=1e-6, dt=1e-6, emissivity=1.0,
                 n_frames=None):
        self.temperature = check_positive(temperature, "temperature", "K")
        self.shape = _shape(shape)
        self.dx, self.dt = check_grid(dx, dt)
        self.emissivity = check_emissivity(emissivity, self.shape)
        self.n_frames = None if n_frames is None else int(n_frames)

    def _read(self, k: int, region: Region) -> np.ndarray:
        rows, cols = (s.stop - s.start for s in region)
        return np.full((rows, cols), self.temperature)

    def describe(self) -> dict:
        return super().describe() | {"temperature_K": self.temperature}


class MovingGaussianBand(Scene):
    """
    A straight hot band moving across a uniform background at constant speed.

    T(x, t) = T_bg + ΔT · exp(−(x − x₀ − v t)² / 2σ²), uniform along y (the band is vertical,
    moving in +x for v > 0).

    Its time average over [t₀, t₁] is closed form (:meth:`time_average`), which is what an ideal
    linear camera with an infinitely small pixel measures; it is the motion-blur limit that the
    paper's integration-time study explores.

    Parameters
    ----------
    background
        Background temperature T_bg [K].
    amplitude
        Peak excess ΔT [K], ≥ 0.
    sigma
        Gaussian width σ [m].
    velocity
        Band speed v [m/s] along +x.
    x0
        Band centre at t = 0 [m].
    shape, dx, dt, emissivity, n_frames
        As for :class:`UniformBlackbody`.
    event_time
        Time [s] a measurement without a start time is centred on (default: when the band is
        at the middle of the frame).

    Examples
    --------
    >>> band = MovingGaussianBand(300.0, 500.0, sigma=5e-6, velocity=2.0, x0=20e-6,
    ...                           shape=(4, 80), dx=1e-6, dt=1e-6)
    >>> round(float(band.frame(0).max()), 1)  # centre at 21 µm at t = 0.5 µs; samples at 20.5, 21.5
    797.5
    """

    def __init__(self, background=AMBIENT_TEMPERATURE, amplitude=500.0, sigma=5e-6, velocity=4.1667,
                 x0=0.0, shape=(64, 256), dx=1e-6, dt=0.2e-6, emissivity=1.0, n_frames=None,
                 event_time=None):
        self.background = check_positive(background, "background", "K")
        self.amplitude = float(amplitude)
        if not math.isfinite(self.amplitude) or self.amplitude < 0:
            raise RadiosimError(f"amplitude must be finite and ≥ 0 [K], got {amplitude!r}")
        self.sigma = check_positive(sigma, "sigma", "m")
        self.velocity = float(velocity)
        if not math.isfinite(self.velocity) or self.velocity == 0:
            raise RadiosimError(f"velocity must be finite and non-zero [m/s], got {velocity!r}")
        self.x0 = float(x0)
        self.shape = _shape(shape)
        self.dx, self.dt = check_grid(dx, dt)
        self.emissivity = check_emissivity(emissivity, self.shape)
        self.n_frames = None if n_frames is None else int(n_frames)
        if event_time is None:
            event_time = max(0.0, (0.5 * self.shape[1] * self.dx - self.x0) / self.velocity)
        self.event_time = float(event_time)

    def temperature(self, x, t) -> np.ndarray:
        """Temperature [K] at position x [m] and time t [s]."""
        x = np.asarray(x, dtype=float)
        z = (x - self.x0 - self.velocity * t) / self.sigma
        return self.background + self.amplitude * np.exp(-0.5 * z * z)

    def time_average(self, x, t0: float, t1: float) -> np.ndarray:
        """
        Exact time average of the temperature [K] at x [m] over [t0, t1] [s].

        ∫ exp(−(x − x₀ − v t)²/2σ²) dt / (t₁ − t₀) = σ √(π/2) / (v (t₁ − t₀)) ·
        [erf((x − x₀ − v t₀)/√2σ) − erf((x − x₀ − v t₁)/√2σ)].
        """
        if not t1 > t0:
            raise RadiosimError(f"need t1 > t0, got t0={t0!r}, t1={t1!r}")
        x = np.asarray(x, dtype=float)
        s = math.sqrt(2) * self.sigma
        bracket = erf((x - self.x0 - self.velocity * t0) / s) - erf(
            (x - self.x0 - self.velocity * t1) / s
        )
        return self.background + self.amplitude * self.sigma * math.sqrt(math.pi / 2) * bracket / (
            self.velocity * (t1 - t0)
        )

    def _read(self, k: int, region: Region) -> np.ndarray:
        x = (np.arange(region[1].start, region[1].stop) + 0.5) * self.dx
        row = self.temperature(x, (k + 0.5) * self.dt)
        return np.broadcast_to(row, (region[0].stop - region[0].start, row.size))

    def describe(self) -> dict:
        return super().describe() | {
            "background_K": self.background,
            "amplitude_K": self.amplitude,
            "sigma_m": self.sigma,
            "velocity_m_per_s": self.velocity,
            "x0_m": self.x0,
        }


class StepEdge(Scene):
    """
    A straight vertical edge between a hot and a cold half-plane: the size-of-source limit.

    T = T_hot for x < x_edge, T_cold beyond. A sample that the edge crosses holds the area
    average of its two parts, so a pixel's linear reading is exactly
    f·T_hot + (1 − f)·T_cold with f the hot fraction of its footprint (:meth:`hot_fraction`),
    and a pixel whose footprint lies wholly on one side reads that side exactly. With the edge
    on a sample boundary every sample is pure, and a radiometric pixel reads exactly the
    temperature of the area-weighted radiance, L⁻¹(f·L(T_hot) + (1 − f)·L(T_cold)).

    Parameters
    ----------
    hot, cold
        Temperatures [K] left and right of the edge.
    edge
        Edge position x [m] from the scene's left edge.
    shape, dx, dt, emissivity, n_frames
        As for :class:`UniformBlackbody`.

    Examples
    --------
    >>> edge = StepEdge(1000.0, 300.0, edge=2.5e-6, shape=(2, 5), dx=1e-6)
    >>> np.round(edge.frame(0)[0], 9).tolist()
    [1000.0, 1000.0, 650.0, 300.0, 300.0]
    """

    def __init__(self, hot=1000.0, cold=AMBIENT_TEMPERATURE, edge=32e-6, shape=(64, 64), dx=1e-6,
                 dt=1e-6, emissivity=1.0, n_frames=None):
        self.hot = check_positive(hot, "hot", "K")
        self.cold = check_positive(cold, "cold", "K")
        self.edge = float(edge)
        self.shape = _shape(shape)
        self.dx, self.dt = check_grid(dx, dt)
        if not 0 <= self.edge <= self.shape[1] * self.dx:
            raise RadiosimError(f"edge {edge!r} m is outside the scene (0 to "
                                f"{self.shape[1] * self.dx:g} m)")
        self.emissivity = check_emissivity(emissivity, self.shape)
        self.n_frames = None if n_frames is None else int(n_frames)

    def hot_fraction(self, x0, x1) -> np.ndarray:
        """Hot fraction of the interval [x0, x1] [m] (dimensionless)."""
        x0, x1 = np.asarray(x0, dtype=float), np.asarray(x1, dtype=float)
        return np.clip((self.edge - x0) / (x1 - x0), 0.0, 1.0)

    def _read(self, k: int, region: Region) -> np.ndarray:
        j = np.arange(region[1].start, region[1].stop)
        f = self.hot_fraction(j * self.dx, (j + 1) * self.dx)
        row = self.cold + f * (self.hot - self.cold)
        return np.broadcast_to(row, (region[0].stop - region[0].start, row.size))

    def describe(self) -> dict:
        return super().describe() | {"hot_K": self.hot, "cold_K": self.cold,
                                     "edge_m": self.edge}

"""
The built-in segmented-chip scene: a kinematic thermal model of orthogonal cutting.

The paper's FEA movie (AdvantEdge, AISI 1045, 250 m/min, 0.3 mm feed) is not public, so radiosim
ships a closed-form, physically motivated temperature field of orthogonal cutting with a
segmented chip, periodic in time with the segmentation period, that can be evaluated at any time
on any grid. Its specification is ``shared/SCENE.md`` (summarised in ``docs/scene.md``); the
terms, superposed on the initial temperature T₀, are:

1.  the primary shear zone, a smooth step T_b(ξ) across the shear plane L0;
2.  the forming shear band on L0, growing through the cycle and narrowing as it intensifies;
3.  released bands carried up the rake face with the chip (stick–slip) and diffusing;
4.  the secondary (friction) zone along the rake face: Jaeger's high-Péclet moving band source,
    with a periodic modulation that travels with the chip;
5.  the tool, heated through the rake face (erfc conduction plus a damped periodic part);
6.  the workpiece, with the primary-zone step and a thin heated layer on the machined surface;
7.  regions (air, workpiece, chip with a saw-tooth free surface, tool), returned as a map so
    each region can carry its own emissivity.

Everything that does not move (geometry, the primary zone, the secondary zone's mean and the
two static fields of its travelling modulation, the tool, the workpiece) is computed once per
grid; a frame evaluates only the moving terms, on the samples they can reach.

Coordinates: lab frame x to the right, y up, origin at the bottom-left corner of the field of
view; array row 0 is the top of the field (y = height), as in an image.

References
----------
-   Whitenton, E. P., Heigel, J. C. & Ivester, R. W. (2009). ASME MSEC2009-84319.
-   Jaeger, J. C. (1942). Moving sources of heat and the temperature at sliding contacts.
    Proc. R. Soc. N.S.W. 76, 203–224 (the high-Péclet band source).
-   Merchant, M. E. (1945) and Lee & Shaffer (1951) for the shear-angle relation
    tan φ = r cos α / (1 − r sin α).
"""

from __future__ import annotations

import dataclasses
import math
import re
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import RegularGridInterpolator
from scipy.signal import fftconvolve
from scipy.special import erfc

from radiosim.config import build_from_toml, dumps_toml, edge_field, from_table, to_table
from radiosim.errors import RadiosimError
from radiosim.scenes.base import Region, Scene, SceneFrame, check_emissivity, check_grid
from radiosim.units import CELSIUS_OFFSET

__all__ = ["ChipParameters", "SegmentedChip", "REGIONS", "COLUMNS"]

#: Region codes of :meth:`SegmentedChip.regions`.
REGIONS = {"air": 0, "workpiece": 1, "chip": 2, "tool": 3}
#: Reference columns: distance from the rake face, along the shear plane L0, where each
#: vertical column of pixels crosses L0 [m]. Column I is the paper's (near the free surface).
COLUMNS = {"I": 440e-6, "II": 300e-6, "III": 160e-6}

_NEGLIGIBLE = 1e-3  # K: moving terms below this are not evaluated


def _reach(amplitude: float) -> float:
    """Distance in σ beyond which a Gaussian of peak ``amplitude`` [K] is below 1 mK."""
    return math.sqrt(2.0 * math.log(max(abs(amplitude), 2 * _NEGLIGIBLE) / _NEGLIGIBLE))
_FADE_REACH = 10.0  # the rake-face fade is 1 − O(e^{−20}) beyond 10 fade lengths
_UM, _US = 1e-6, 1e-6


def _param(default, toml_key, scale=1.0, offset=0.0, doc=""):
    """A parameter with its TOML key (edge units) and conversion: SI = value·scale + offset."""
    return edge_field(default, toml_key, scale, offset, doc,
                      kind="int" if isinstance(default, int) else "number")


@dataclass(frozen=True)
class ChipParameters:
    """
    Parameters of the segmented-chip scene, in SI units (K, m, s, rad).

    TOML files use the units of ``shared/SCENE.md`` with the unit in each key (``period_us``,
    ``band_width_um``, ``initial_temperature_C``); :meth:`from_toml` and :meth:`to_toml`
    convert. The defaults are SCENE.md's values except the eight that
    :func:`radiosim.paper.chip_calibration.calibrate` fitted to the paper's figures
    (slip fraction, primary rise, band amplitude, widths and diffusivity, secondary rise,
    modulation); docs/scene.md gives the fit and its result.
    """

    # Process and frame
    cutting_speed: float = _param(250 / 60, "cutting_speed_m_per_min", 1 / 60,
                                  doc="workpiece speed V [m/s]")
    uncut_thickness: float = _param(300e-6, "uncut_thickness_um", _UM, doc="h [m]")
    initial_temperature: float = _param(293.15, "initial_temperature_C", 1.0, CELSIUS_OFFSET,
                                        doc="T₀ [K]")
    ambient_temperature: float = _param(293.15, "ambient_temperature_C", 1.0, CELSIUS_OFFSET,
                                        doc="air [K]")
    rake_angle: float = _param(math.radians(-7), "rake_angle_deg", math.pi / 180, doc="α [rad]")
    clearance_angle: float = _param(math.radians(7), "clearance_angle_deg", math.pi / 180,
                                    doc="γ [rad]")
    edge_radius: float = _param(20e-6, "edge_radius_um", _UM, doc="r_e [m]")
    field_width: float = _param(960e-6, "field_width_um", _UM, doc="width of the field of view [m]")
    field_height: float = _param(742e-6, "field_height_um", _UM, doc="height of the field of view [m]")
    tool_tip_x: float = _param(700e-6, "tool_tip_x_um", _UM, doc="tool tip x [m]")
    tool_tip_y: float = _param(250e-6, "tool_tip_y_um", _UM, doc="tool tip y [m]")
    # Segmentation
    period: float = _param(90e-6, "period_us", _US, doc="segmentation period P [s]")
    chip_ratio: float = _param(0.55, "chip_ratio", doc="r = h/h_c")
    segmentation_degree: float = _param(0.23, "segmentation_degree", doc="G_s")
    slip_fraction: float = _param(0.5026, "slip_fraction", doc="ε of the stick–slip")
    slip_time: float = _param(6e-6, "slip_time_us", _US, doc="τ_s [s]")
    # Primary zone
    primary_rise: float = _param(213.1, "primary_rise_K", doc="ΔT_p [K]")
    primary_width: float = _param(12e-6, "primary_width_um", _UM, doc="w_p [m]")
    primary_offset: float = _param(-1.5e-6, "primary_offset_um", _UM, doc="ξ_off [m]")
    # Shear bands
    band_amplitude: float = _param(408.3, "band_amplitude_K", doc="A [K]")
    band_width: float = _param(16.27e-6, "band_width_um", _UM, doc="σ_rel [m]")
    band_initial_width: float = _param(21.07e-6, "band_initial_width_um", _UM, doc="σ_init [m]")
    band_exponent_tip: float = _param(0.35, "band_exponent_tip", doc="m at the tool tip")
    band_exponent_reach: float = _param(0.6, "band_exponent_reach",
                                        doc="m reaches 1 at this fraction of h_c")
    chip_diffusivity: float = _param(4.635e-6, "chip_diffusivity_um2_per_us", 1e-6,
                                     doc="a_c [m²/s]")
    released_bands: int = _param(6, "released_bands", doc="bands k = 0 … N−1")
    rake_fade: float = _param(2e-6, "rake_fade_um", _UM, doc="band fade at the rake face [m]")
    # Secondary (friction) zone
    secondary_rise: float = _param(343.4, "secondary_rise_K", doc="ΔT_s [K]")
    contact_length: float = _param(450e-6, "contact_length_um", _UM, doc="L_c [m]")
    full_flux_fraction: float = _param(0.55, "full_flux_fraction", doc="q = 1 up to this × L_c")
    secondary_diffusivity: float = _param(6.5e-6, "secondary_diffusivity_um2_per_us", 1e-6,
                                          doc="a_s [m²/s]")
    tool_sink: float = _param(0.2, "tool_sink", doc="κ")
    tool_sink_depth: float = _param(4e-6, "tool_sink_depth_um", _UM, doc="λ [m]")
    modulation: float = _param(0.2645, "modulation", doc="a")
    modulation_phase: float = _param(0.10, "modulation_phase", doc="θ_m")
    # Tool and workpiece
    tool_conduction_length: float = _param(100e-6, "tool_conduction_length_um", _UM,
                                           doc="L_t [m]")
    tool_periodic_depth: float = _param(25e-6, "tool_periodic_depth_um", _UM, doc="δ_ω [m]")
    surface_rise: float = _param(200.0, "surface_rise_K", doc="A_ms [K]")
    surface_width: float = _param(5e-6, "surface_width_um", _UM, doc="σ₀ [m]")
    workpiece_diffusivity: float = _param(11e-6, "workpiece_diffusivity_um2_per_us", 1e-6,
                                          doc="a_w [m²/s]")

    def __post_init__(self):
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise RadiosimError(f"chip parameter {f.name} must be a finite number, "
                                    f"got {value!r}")
        positive = ["cutting_speed", "uncut_thickness", "initial_temperature",
                    "ambient_temperature", "field_width", "field_height", "period", "slip_time",
                    "primary_width", "band_width", "band_initial_width", "chip_diffusivity",
                    "rake_fade", "contact_length", "secondary_diffusivity", "tool_sink_depth",
                    "tool_conduction_length", "tool_periodic_depth", "surface_width",
                    "workpiece_diffusivity", "edge_radius"]
        for name in positive:
            if not getattr(self, name) > 0:
                raise RadiosimError(f"chip parameter {name} must be > 0, got "
                                    f"{getattr(self, name)!r}")
        for name in ("chip_ratio", "segmentation_degree", "slip_fraction", "full_flux_fraction",
                     "band_exponent_reach"):
            if not 0 < getattr(self, name) < 1:
                raise RadiosimError(f"chip parameter {name} must be in (0, 1), got "
                                    f"{getattr(self, name)!r}")
        if not self.slip_time < self.period:
            raise RadiosimError("slip_time must be shorter than the period")
        if abs(math.degrees(self.rake_angle + self.clearance_angle)) > 1e-9:
            raise RadiosimError(
                "the model's tool is a right-angle wedge: rake angle must equal −clearance angle "
                f"(got α = {math.degrees(self.rake_angle):g}°, "
                f"γ = {math.degrees(self.clearance_angle):g}°)"
            )
        if int(self.released_bands) != self.released_bands or self.released_bands < 1:
            raise RadiosimError(f"released_bands must be a whole number ≥ 1, got "
                                f"{self.released_bands!r}")

    # -- derived quantities ---------------------------------------------------------------

    @property
    def chip_speed(self) -> float:
        """Chip speed up the rake face V_c = r·V [m/s]."""
        return self.chip_ratio * self.cutting_speed

    @property
    def chip_thickness(self) -> float:
        """Mean chip thickness h_c = h / r [m]."""
        return self.uncut_thickness / self.chip_ratio

    @property
    def segment_pitch(self) -> float:
        """Segment pitch along the chip p_c = V_c·P [m]."""
        return self.chip_speed * self.period

    @property
    def shear_angle(self) -> float:
        """φ = atan(r cos α / (1 − r sin α)) [rad]."""
        a = self.rake_angle
        return math.atan(self.chip_ratio * math.cos(a) / (1 - self.chip_ratio * math.sin(a)))

    @property
    def band_angle(self) -> float:
        """θ_b, angle between L0 and the rake face [rad]."""
        return math.pi / 2 - (self.shear_angle + self.clearance_angle)

    @property
    def max_thickness(self) -> float:
        """h_max = 2h_c/(2 − G_s) [m]."""
        return 2 * self.chip_thickness / (2 - self.segmentation_degree)

    @property
    def min_thickness(self) -> float:
        """h_min = h_max (1 − G_s) [m]."""
        return self.max_thickness * (1 - self.segmentation_degree)

    # -- TOML -----------------------------------------------------------------------------

    def to_dict(self) -> dict:
        """Values in the TOML edge units, keyed by their TOML names."""
        return to_table(self)

    @classmethod
    def from_dict(cls, data: dict) -> ChipParameters:
        """Parameters from TOML-unit values (missing keys take the defaults)."""
        return from_table(cls, data, "chip parameters")

    @classmethod
    def from_toml(cls, path) -> ChipParameters:
        """Parameters from a TOML file (a ``[chip]`` table or top-level keys)."""
        return build_from_toml(path, "chip parameters",
                               lambda data, base: cls.from_dict(data.get("chip", data)))

    def to_toml(self, path=None) -> str:
        """The parameters as TOML text (written to ``path`` if given)."""
        comments = {f.metadata["toml"]: re.sub(r"\s*\[.*?\]", "", f.metadata["doc"])
                    for f in dataclasses.fields(self)}
        text = dumps_toml({"chip": self.to_dict()}, tables=("chip",), comments=comments,
                          header="radiosim segmented-chip scene parameters (units in the keys)")
        if path is not None:
            Path(path).write_text(text, encoding="utf-8")
        return text

    def replace(self, **changes) -> ChipParameters:
        return dataclasses.replace(self, **changes)


def smooth_step(z):
    """S(z) = ½(1 + tanh z)."""
    return 0.5 * (1.0 + np.tanh(z))


def smoothstep(x):
    """H(x) = x²(3 − 2x) on clip(x, 0, 1)."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def jaeger_band_source(p: ChipParameters, s_max: float, n_max: float, step: float):
    """
    Tabulate the secondary zone's shape I(s, n)·(1 − κ e^{−n/λ}), normalised to a maximum of 1.

    I(s, n) = ∫₀^s q(s′) (s − s′)^{−½} exp(−n² V_c / 4 a_s (s − s′)) ds′ is evaluated as a
    discrete convolution of q (piecewise constant on cells of ``step``) with the kernel
    integrated exactly over each cell, using the antiderivative
    G(r) = 2√r e^{−c/r} − 2√(πc) erfc(√(c/r)), c = n² V_c / 4 a_s.

    Returns
    -------
    s, n : numpy.ndarray
        Grid along and normal to the rake face [m].
    shape : numpy.ndarray
        Dimensionless field (len(n), len(s)), maximum 1.
    """
    s = np.arange(0.0, s_max + step, step)
    n = np.arange(0.0, n_max + step, step)
    centres = s[:-1] + 0.5 * step
    full = p.full_flux_fraction * p.contact_length
    q = np.clip((p.contact_length - centres) / (p.contact_length - full), 0.0, 1.0)
    c = (n[:, None] ** 2) * p.chip_speed / (4.0 * p.secondary_diffusivity)
    r = s[None, :]  # kernel abscissae r = m·step, m = 0 … M
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(r > 0, c / np.where(r > 0, r, 1.0), np.inf)
        g = np.where(r > 0, 2 * np.sqrt(r) * np.exp(-ratio)
                     - 2 * np.sqrt(np.pi * c) * erfc(np.sqrt(ratio)), 0.0)
    kernel = np.diff(g, axis=1)  # ∫ over [m·step, (m+1)·step] of r^{−½} e^{−c/r} dr
    # I(s_j) = Σ_{i<j} q_i · kernel[j − 1 − i]
    conv = fftconvolve(kernel, q[None, :], axes=1)[:, : s.size - 1]
    field_ = np.zeros((n.size, s.size))
    field_[:, 1:] = np.clip(conv, 0.0, None)
    field_ *= 1.0 - p.tool_sink * np.exp(-n / p.tool_sink_depth)[:, None]
    return s, n, field_ / field_.max()


class _Geometry:
    """Everything about a grid that does not move: coordinates, static fields, masks."""

    def __init__(self, p: ChipParameters, shape: tuple[int, int], dx: float):
        rows, cols = shape
        x = (np.arange(cols) + 0.5) * dx
        y = p.field_height - (np.arange(rows) + 0.5) * dx
        dxv = x[None, :] - p.tool_tip_x
        dyv = y[:, None] - p.tool_tip_y
        a, g = p.rake_angle, p.clearance_angle
        s = dxv * math.sin(a) + dyv * math.cos(a)  # along the rake face [m]
        u = dxv * math.cos(g) + dyv * math.sin(g)  # into the tool [m]
        n = -u  # into the chip [m]
        tb = p.band_angle
        zeta = s - n / math.tan(tb)  # constant on lines parallel to L0 [m]
        xi = zeta * math.sin(tb)  # signed distance from L0, > 0 in the chip [m]
        self.x, self.y = x, y

        # Regions that do not move: tool, workpiece; chip up to the thickest free surface.
        re = p.edge_radius
        rounded = (s < re) & (u < re) & ((s - re) ** 2 + (u - re) ** 2 > re**2)
        tool = (u >= 0) & (s >= 0) & ~rounded
        chip_max = ~tool & (zeta >= 0) & (n >= 0) & (n <= p.max_thickness)
        left = x[None, :] < p.tool_tip_x
        workpiece = ~tool & ~chip_max & np.where(
            left, y[:, None] < p.tool_tip_y + p.uncut_thickness, y[:, None] < p.tool_tip_y)
        self.tool, self.workpiece, self.chip_max = tool, workpiece, chip_max
        self.static_regions = np.full(shape, REGIONS["air"], dtype=np.uint8)
        self.static_regions[workpiece] = REGIONS["workpiece"]
        self.static_regions[tool] = REGIONS["tool"]
        self.static_regions[chip_max] = REGIONS["chip"]
        # Where the saw-tooth free surface can lie: chip or air depending on time.
        self.surface_zone = chip_max & (n > p.min_thickness)

        t0 = p.initial_temperature
        primary = p.primary_rise * smooth_step((xi - p.primary_offset) / p.primary_width)

        # Secondary zone (mean field) and the two static fields of its travelling modulation.
        step = 0.5e-6
        s_max = max(float(s[chip_max | tool].max(initial=0.0)), p.contact_length) + 2 * step
        n_max = float(n[chip_max].max(initial=0.0)) + 2 * step
        grid_s, grid_n, jaeger = jaeger_band_source(p, s_max, min(n_max, 400e-6), step)
        lookup = RegularGridInterpolator((grid_n, grid_s), jaeger, bounds_error=False,
                                         fill_value=0.0)
        phase = 2 * np.pi * s / p.segment_pitch
        static = np.full(shape, p.ambient_temperature)
        cos_field = np.zeros(shape)
        sin_field = np.zeros(shape)

        # Chip (static part).
        idx = np.nonzero(chip_max)
        secondary = p.secondary_rise * lookup(np.column_stack(
            [n[idx], np.clip(s[idx], 0.0, None)]))
        static[idx] = t0 + primary[idx] + secondary
        cos_field[idx] = p.modulation * secondary * np.cos(phase[idx])
        sin_field[idx] = p.modulation * secondary * np.sin(phase[idx])

        # Tool: the rake-face interface temperature conducted in (erfc) and its periodic part.
        idx = np.nonzero(tool)
        s_t, depth = np.clip(s[idx], 0.0, None), np.clip(u[idx], 0.0, None)
        interface_s = np.minimum(s_t, p.contact_length)
        beyond = erfc(np.clip(s_t - p.contact_length, 0.0, None) / p.tool_conduction_length)
        xi_face = interface_s * math.sin(tb)  # on the rake face, n = 0
        face_primary = p.primary_rise * smooth_step((xi_face - p.primary_offset)
                                                    / p.primary_width)
        face_secondary = p.secondary_rise * lookup(np.column_stack(
            [np.zeros_like(interface_s), interface_s]))
        static[idx] = t0 + (face_primary + face_secondary) * beyond * erfc(
            depth / p.tool_conduction_length)
        periodic = p.modulation * face_secondary * beyond * np.exp(-depth / p.tool_periodic_depth)
        cos_field[idx] = periodic * np.cos(phase[idx])
        sin_field[idx] = periodic * np.sin(phase[idx])

        # Workpiece: primary-zone step ahead of the tool, faded behind the tip, and the
        # machined-surface layer broadening with the time since it was cut.
        idx = np.nonzero(workpiece)
        behind = np.clip(x[idx[1]] - p.tool_tip_x, 0.0, None)
        fade = np.exp(-behind / p.primary_width)
        sigma2 = p.surface_width**2 + 2 * p.workpiece_diffusivity * behind / p.cutting_speed
        below = np.clip(p.tool_tip_y - y[idx[0]], 0.0, None)
        layer = np.where(x[idx[1]] >= p.tool_tip_x, p.surface_rise * np.sqrt(
            p.surface_width**2 / sigma2) * np.exp(-below**2 / (2 * sigma2)), 0.0)
        static[idx] = t0 + primary[idx] * fade + layer

        self.static = static
        self.cos_field, self.sin_field = cos_field, sin_field
        self.s, self.n, self.zeta, self.xi = s, n, zeta, xi
        # Band terms reach the chip and, for the forming band, the workpiece near L0.
        reach = _reach(p.band_amplitude) * max(p.band_initial_width, p.band_width)
        self.forming_zone = (chip_max | (workpiece & left)) & (np.abs(xi) < reach)
        self.rake_fade = smooth_step(n / p.rake_fade)
        reach_n = p.band_exponent_reach * p.chip_thickness
        self.band_exponent = p.band_exponent_tip + (1 - p.band_exponent_tip) * np.clip(
            n / reach_n, 0.0, 1.0)


class _RegionData:
    """The static data of one rectangular region, as flat index sets and gathered values, so
    that a frame only touches the samples each moving term can reach."""

    def __init__(self, p: ChipParameters, g: _Geometry, region: Region):
        rs, cs = region

        def sub(a):
            return np.ascontiguousarray(a[rs, cs]).reshape(-1)

        self.static = np.ascontiguousarray(g.static[rs, cs])
        self.regions = np.ascontiguousarray(g.static_regions[rs, cs])
        cos_field, sin_field = sub(g.cos_field), sub(g.sin_field)
        # The modulation's amplitude dies away from the rake face: drop it below 1 mK.
        self.periodic = np.flatnonzero(np.hypot(cos_field, sin_field) > _NEGLIGIBLE)
        self.cos_field, self.sin_field = cos_field[self.periodic], sin_field[self.periodic]
        zeta, fade = sub(g.zeta), sub(g.rake_fade)
        n_all = sub(g.n)
        self.chip = np.flatnonzero(sub(g.chip_max))
        if self.chip.size:
            z = zeta[self.chip]
            # A profile grid anchored at ζ = 0 (multiples of the step), so that any region
            # interpolates the same nodes as the whole frame.
            step = min(0.05e-6, p.band_width / 100)
            first, last = math.floor(z.min() / step) - 1, math.ceil(z.max() / step) + 2
            self.zeta_grid = np.arange(first, last) * step
            position = z / step - first
            self.zeta_index = np.minimum(position.astype(np.intp), self.zeta_grid.size - 2)
            self.zeta_frac = position - self.zeta_index
            # The rake-face fade S(n / 2 µm) differs from 1 by < 1e-8 beyond 20 µm.
            self.chip_faded = np.flatnonzero(n_all[self.chip] < _FADE_REACH * p.rake_fade)
            self.chip_fade = fade[self.chip][self.chip_faded]
        forming = np.flatnonzero(sub(g.forming_zone))
        xi = sub(g.xi)[forming]
        order = np.argsort(np.abs(xi), kind="stable")
        self.forming = forming[order]
        self.forming_abs_xi = np.abs(xi[order])
        self.forming_xi2 = xi[order] ** 2
        self.forming_exponent = sub(g.band_exponent)[self.forming]
        self.forming_faded = n_all[self.forming] < _FADE_REACH * p.rake_fade
        self.forming_fade = np.where(self.forming_faded, fade[self.forming], 1.0)
        self.surface = np.flatnonzero(sub(g.surface_zone))
        self.surface_zeta = zeta[self.surface]
        self.surface_n = sub(g.n)[self.surface]
        t0, rise = p.initial_temperature, p.primary_rise
        self.background = lambda xi_: t0 + rise * float(
            smooth_step((xi_ - p.primary_offset) / p.primary_width))


class SegmentedChip(Scene):
    """
    The kinematic segmented-chip scene of orthogonal cutting, periodic in time.

    Parameters
    ----------
    params
        :class:`ChipParameters` (default: the calibrated ones), or a path to a TOML file.
    dx
        Sample pitch [m] (default 960/1440 µm, the paper's movie).
    dt
        Frame interval [s] (default 0.2 µs, the paper's movie).
    emissivity
        A grey scalar, a spectral curve, or a dict of region name → scalar or curve
        (``{"chip": 0.3, "tool": 0.5, "workpiece": 0.3, "air": 1.0}``, missing regions 1).
    cycles
        Frames are defined for ``cycles`` segmentation periods (``None``: unbounded).

    Attributes
    ----------
    event_time : float
        Mid-time of the frame that holds the fully developed shear band at the end of the tenth
        cycle [s], so that windows up to 1.8 ms centred on it start after t = 0.

    Examples
    --------
    >>> scene = SegmentedChip(dx=4e-6, dt=1e-6)
    >>> scene.shape
    (186, 240)
    >>> t = scene.temperature(scene.event_time)
    >>> 900 < float(t.max()) < 1100
    True
    """

    def __init__(self, params: ChipParameters | str | Path | None = None, dx: float = 960e-6 / 1440,
                 dt: float = 0.2e-6, emissivity=1.0, cycles: int | None = None):
        if params is None:
            params = ChipParameters()
        elif isinstance(params, (str, Path)):
            params = ChipParameters.from_toml(params)
        elif not isinstance(params, ChipParameters):
            raise RadiosimError(f"params must be ChipParameters or a TOML path, got "
                                f"{type(params).__name__}")
        self.params = params
        self.dx, self.dt = check_grid(dx, dt)
        self.shape = (int(round(params.field_height / self.dx)),
                      int(round(params.field_width / self.dx)))
        if min(self.shape) < 2:
            raise RadiosimError(f"dx = {dx!r} m leaves fewer than 2 samples across the field")
        self.n_frames = None if cycles is None else int(round(cycles * params.period / self.dt))
        frames_per_cycle = params.period / self.dt
        self.event_time = (10 * frames_per_cycle - 0.5) * self.dt
        self._region_emissivity = None
        if isinstance(emissivity, dict):
            unknown = set(emissivity) - set(REGIONS)
            if unknown:
                raise RadiosimError(f"unknown region(s) {sorted(unknown)} in emissivity; "
                                    f"regions are {', '.join(REGIONS)}")
            self._region_emissivity = {name: check_emissivity(emissivity.get(name, 1.0),
                                                               self.shape) for name in REGIONS}
            emissivity = 1.0
        self.emissivity = check_emissivity(emissivity, self.shape)
        self._geometry = None
        self._regions: dict[tuple, _RegionData] = {}
        self._lock = threading.RLock()

    @property
    def geometry(self) -> _Geometry:
        """Static fields of the grid (built on first use)."""
        with self._lock:
            if self._geometry is None:
                self._geometry = _Geometry(self.params, self.shape, self.dx)
            return self._geometry

    # -- time ---------------------------------------------------------------------------------

    def _phase(self, t: float):
        p = self.params
        tau = t % p.period
        theta = tau / p.period
        d = p.chip_speed * ((1 - p.slip_fraction) * tau
                            + p.slip_fraction * p.period * float(smoothstep(tau / p.slip_time)))
        return tau, theta, d

    # -- evaluation ---------------------------------------------------------------------------

    def _prepared(self, region: Region) -> _RegionData:
        key = (region[0].start, region[0].stop, region[1].start, region[1].stop)
        with self._lock:
            data = self._regions.get(key)
            if data is None:
                if len(self._regions) >= 4:
                    self._regions.pop(next(iter(self._regions)))
                data = self._regions[key] = _RegionData(self.params, self.geometry, region)
            return data

    def _evaluate(self, t: float, region: Region, want_regions: bool = False):
        p, r = self.params, self._prepared(region)
        tau, theta, d = self._phase(t)
        temperature = r.static.copy()
        flat = temperature.reshape(-1)
        # Travelling modulation of the secondary zone (chip and tool) [K].
        angle = 2 * np.pi * (theta - p.modulation_phase)
        flat[r.periodic] += math.cos(angle) * r.cos_field + math.sin(angle) * r.sin_field

        # Released bands, carried with the chip and diffusing: a profile along ζ [K].
        if r.chip.size:
            sin_b = math.sin(p.band_angle)
            profile = np.zeros(r.zeta_grid.size)
            for k in range(int(p.released_bands)):
                zk = d + k * p.segment_pitch
                sigma2 = p.band_width**2 + 2 * p.chip_diffusivity * (tau + k * p.period)
                amplitude = (p.band_amplitude + r.background(0.0)
                             - r.background(zk * sin_b)) * math.sqrt(p.band_width**2 / sigma2)
                reach = _reach(amplitude) * math.sqrt(sigma2) / sin_b
                lo, hi = np.searchsorted(r.zeta_grid, (zk - reach, zk + reach))
                dz = (r.zeta_grid[lo:hi] - zk) * sin_b
                profile[lo:hi] += amplitude * np.exp(-dz * dz / (2 * sigma2))
            left = profile[r.zeta_index]
            excess = left + r.zeta_frac * (profile[r.zeta_index + 1] - left)
            excess[r.chip_faded] *= r.chip_fade
            flat[r.chip] += excess

        # The forming band on L0, on the samples within reach of its current width [K].
        base = min(max((theta - p.slip_time / p.period) / (1 - p.slip_time / p.period), 0.0),
                   1.0)
        if base > 0 and r.forming.size:
            widest = p.band_width + (p.band_initial_width - p.band_width) * (1 - base) ** 2
            reach = _reach(p.band_amplitude * base) * max(widest, p.band_width)
            n = np.searchsorted(r.forming_abs_xi, reach)
            f = np.exp(r.forming_exponent[:n] * math.log(base))
            sigma = (1 - f) ** 2
            sigma *= p.band_initial_width - p.band_width
            sigma += p.band_width
            sigma *= sigma
            sigma *= -2.0
            excess = np.divide(r.forming_xi2[:n], sigma)
            np.exp(excess, out=excess)
            excess *= f
            excess *= r.forming_fade[:n]
            flat[r.forming[:n]] += p.band_amplitude * excess

        # The saw-tooth free surface: beyond it, air.
        air = None
        if r.surface.size:
            frac = np.mod((r.surface_zeta - d) / p.segment_pitch, 1.0)
            outline = p.min_thickness + (p.max_thickness - p.min_thickness) * (1 - frac)
            air = r.surface[r.surface_n > outline]
            flat[air] = p.ambient_temperature
        if not want_regions:
            return temperature
        regions = r.regions.copy()
        if air is not None:
            regions.reshape(-1)[air] = REGIONS["air"]
        return temperature, regions

    def _full(self) -> Region:
        return (slice(0, self.shape[0]), slice(0, self.shape[1]))

    def temperature(self, t: float, region: Region | None = None) -> np.ndarray:
        """Temperature field [K] at time t [s] (any time ≥ 0; the scene is periodic)."""
        if not (math.isfinite(t) and t >= 0):
            raise RadiosimError(f"time must be finite and ≥ 0 [s], got {t!r}")
        return self._evaluate(float(t), region or self._full())

    def regions(self, t: float, region: Region | None = None) -> np.ndarray:
        """Region map at time t [s]: codes of :data:`REGIONS` (air 0, workpiece 1, chip 2,
        tool 3)."""
        return self._evaluate(float(t), region or self._full(), want_regions=True)[1]

    def _read(self, k: int, region: Region) -> np.ndarray:
        return self._evaluate((k + 0.5) * self.dt, region)

    def _sample(self, k: int, region: Region) -> SceneFrame:
        """Temperature and, with an emissivity per region, the region codes of the same
        evaluation."""
        if self._region_emissivity is None:
            return super()._sample(k, region)
        temperature, regions = self._evaluate((k + 0.5) * self.dt, region, want_regions=True)
        return SceneFrame(temperature, 1.0, regions=regions, index=k,
                          region_emissivity={REGIONS[name]: value for name, value
                                             in self._region_emissivity.items()})

    # -- reference locations -----------------------------------------------------------------

    def column_x(self, name: str) -> float:
        """x position [m] of reference Column "I", "II" or "III" (where it crosses L0)."""
        if name not in COLUMNS:
            raise RadiosimError(f"unknown column {name!r}; columns are {', '.join(COLUMNS)}")
        p = self.params
        along = COLUMNS[name] / math.cos(p.shear_angle + p.clearance_angle)
        return p.tool_tip_x - along * math.cos(p.shear_angle)

    def shear_plane(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """End points (x, y) [m] of L0: the tool tip and the elbow on the uncut surface."""
        p = self.params
        length = p.uncut_thickness / math.sin(p.shear_angle)
        return ((p.tool_tip_x, p.tool_tip_y),
                (p.tool_tip_x - length * math.cos(p.shear_angle), p.tool_tip_y
                 + p.uncut_thickness))

    def describe(self) -> dict:
        out = super().describe()
        out.update({f"chip_{k}": v for k, v in self.params.to_dict().items()})
        out["event_time_s"] = self.event_time
        if self._region_emissivity is not None:
            out["emissivity"] = ", ".join(
                f"{k}: {v.name if hasattr(v, 'name') else v}"
                for k, v in self._region_emissivity.items())
        return out

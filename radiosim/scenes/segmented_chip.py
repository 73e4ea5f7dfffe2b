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
grid; a frame evaluates only the moving terms, on the samples they can reach. It does so with a
compiled kernel (numba, :func:`_moving_terms_kernel`: one row-parallel pass writing the frame,
compiled on first use and cached on disk); the numpy implementation it replaces is kept as its
reference (:meth:`SegmentedChip._evaluate_reference`, selected by
``USE_COMPILED_KERNEL = False``), and the two agree to rounding.

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
import weakref
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np
from numba import prange
from scipy.interpolate import RegularGridInterpolator
from scipy.signal import fftconvolve
from scipy.special import erfc

from radiosim.checks import check_positive
from radiosim.config import build_from_toml, dumps_toml, edge_field, from_table, to_table
from radiosim.errors import RadiosimError
from radiosim.files import write_text
from radiosim.kernels import fast_exp, parallel_launch
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
            write_text(path, text)  # atomically
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
        # The interface temperature along the rake face (n = u = 0), for the reflected field.
        self.face_s = np.arange(0.0, s_max + step, step)
        on_face = np.minimum(self.face_s, p.contact_length)
        self.face_temperature = t0 + (
            p.primary_rise * smooth_step((on_face * math.sin(tb) - p.primary_offset)
                                         / p.primary_width)
            + p.secondary_rise * lookup(np.column_stack([np.zeros_like(on_face), on_face]))
        ) * erfc(np.clip(self.face_s - p.contact_length, 0.0, None) / p.tool_conduction_length)

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
            self.zeta_step, self.zeta_first = step, first
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
        self.background_at_l0 = self.background(0.0)
        # For the compiled kernel: the region's place in the grid and its coordinates, and its
        # run layout (built on its first compiled evaluation, see _KernelData).
        self.shape = self.static.shape
        self.x, self.y = g.x[cs], g.y[rs]
        self.kernel: _KernelData | None = None


# -- the compiled moving terms ---------------------------------------------------------------
#
# A frame is the static field plus the moving terms on four index sets of the region
# (_RegionData): the travelling modulation (``periodic``), the released bands (``chip``), the
# forming band (``forming``) and the free surface (``surface``), each stored as runs of columns
# per row (_KernelData). The kernel writes the frame in one pass over the region's rows (blocks
# of rows dealt to the threads in turn): each row is copied from the static field and, while it
# is in cache, each term is applied to its runs in the reference's order (modulation, released
# bands, forming band, surface), so every sample sees the reference's operations in the
# reference's order. The coordinates n, ζ, ξ of a sample are recomputed from its (x, y) with
# _Geometry's arithmetic (bitwise the same; fastmath is off: no reassociation, no FMA
# contraction), so only the modulation's two fields are read per sample besides the static
# field. exp is _exp below, not libm's, so that the loops vectorise (relative error < 1e-15):
# the two implementations differ by rounding only (< 1e-15 relative in temperature, the region
# map identical).

#: Evaluate the moving terms with the compiled kernel (True, the default) or the numpy reference
#: (False). ``SegmentedChip._evaluate(..., compiled=...)`` overrides it for one call.
USE_COMPILED_KERNEL = True

_JIT = dict(cache=True, fastmath=False, nogil=True, error_model="numpy", boundscheck=False)

# Entries of the kernel's constants vector (grid constants, and per frame the four marked *).
(_K_TIP_X, _K_TIP_Y, _K_SIN_A, _K_COS_A, _K_COS_G, _K_SIN_G, _K_TAN_TB, _K_SIN_TB,
 _K_COS, _K_SIN,  # * cos, sin of the modulation's angle
 _K_STEP, _K_FIRST,
 _K_LOG_BASE, _K_REACH,  # * ln(base), |ξ| reach of the forming band
 _K_EXP_TIP, _K_EXP_SLOPE, _K_EXP_REACH, _K_SIGMA, _K_SIGMA_SPAN, _K_AMPLITUDE,
 _K_D,  # * chip displacement d
 _K_PITCH, _K_MIN_T, _K_SPAN_T, _K_AMBIENT, _K_SIZE) = range(26)
# Index sets, in the order the kernel applies them.
_SET_PERIODIC, _SET_CHIP, _SET_FORMING, _SET_SURFACE = range(4)

#: Blocks of rows per thread: dealt in turn, they even out the threads' shares.
_BLOCKS = 8

_NO_PROFILE = np.zeros(2)
_NO_TERMS = np.zeros((0, 3))
_NO_NODES = np.zeros((0, 2), dtype=np.int64)
_NO_REGIONS = np.zeros((1, 1), dtype=np.uint8)

# exp(x) inline and vectorisable: the integrator kernels' (Cody–Waite reduction, Taylor
# polynomial), shared so both evaluate it alike.
_exp = fast_exp


#: The bits of +inf as an int64: a float64 whose bits are ≥ this is +inf or NaN.
_INF_BITS = int(np.array(np.inf).view(np.int64))


@numba.njit(**_JIT)
def _coordinates(xj, dyv, k):
    """(n, ζ) of the sample at x = ``xj``, y − y_tip = ``dyv``: _Geometry's arithmetic."""
    dxv = xj - k[_K_TIP_X]
    s = dxv * k[_K_SIN_A] + dyv * k[_K_COS_A]
    u = dxv * k[_K_COS_G] + dyv * k[_K_SIN_G]
    n = -u
    return n, s - n / k[_K_TAN_TB]


# The spans take views of a row's run of columns and loop from 0 to their size: the index is
# then known to be ≥ 0, which spares numba's negative-index wraparound and lets LLVM vectorise.
# The costly loops (exp, divisions) run over a multiple of _PAD samples, writing scratch space:
# no sample is left to the scalar remainder loop; the x coordinates are padded for them.
_PAD = 16


@numba.njit(**_JIT)
def _padded(size):
    """``size`` rounded up to a multiple of _PAD."""
    return (size + _PAD - 1) // _PAD * _PAD


@numba.njit(**_JIT)
def _chip_span(row, x, dyv, k, profile, fade, faded, position):
    """Released bands on the samples of ``row`` (x coordinates ``x``, padded): the ζ profile
    interpolated, faded at the rake face (``faded``: by ``fade``). ``position`` is scratch."""
    step, first = k[_K_STEP], k[_K_FIRST]
    for j in range(_padded(row.size)):  # vectorised: the profile's fractional index
        n, zeta = _coordinates(x[j], dyv, k)
        position[j] = zeta / step - first  # ≥ 1: the grid starts a step before the region's ζ
    last, one = np.uintp(profile.size - 2), np.uintp(1)  # unsigned: no wraparound
    for j in range(row.size):  # the gather
        index = min(np.uintp(position[j]), last)
        frac = position[j] - index
        left = profile[index]
        excess = left + frac * (profile[index + one] - left)
        if faded:
            excess *= fade[j]
        row[j] += excess


@numba.njit(**_JIT)
def _forming_values(excess, f, xi, x, dyv, k, count):
    """The forming band's exp(ξ²/(−2σ²))·f on ``count`` samples (x coordinates ``x``) into
    ``excess``, 0 where |ξ| is beyond its reach (so that adding it changes nothing); ``f`` and
    ``xi`` are scratch. Two loops: each exp's latency then overlaps the next sample's."""
    sin_tb, reach, log_base = k[_K_SIN_TB], k[_K_REACH], k[_K_LOG_BASE]
    tip, slope, reach_n = k[_K_EXP_TIP], k[_K_EXP_SLOPE], k[_K_EXP_REACH]
    sigma_b, span = k[_K_SIGMA], k[_K_SIGMA_SPAN]
    for j in range(count):
        n, zeta = _coordinates(x[j], dyv, k)
        xi[j] = zeta * sin_tb
        m = tip + slope * min(max(n / reach_n, 0.0), 1.0)
        f[j] = _exp(m * log_base)
    for j in range(count):
        sigma = (1.0 - f[j]) * (1.0 - f[j])
        sigma *= span
        sigma += sigma_b
        sigma *= sigma
        sigma *= -2.0
        value = _exp(xi[j] * xi[j] / sigma)
        value *= f[j]
        excess[j] = value if abs(xi[j]) < reach else 0.0


@numba.njit(**_JIT)
def _forming_values_saturated(excess, x, dyv, k, count, f, sigma):
    """:func:`_forming_values` where every sample has n ≥ the exponent's reach: m = 1, so f
    and σ are the same for all (``f``, ``sigma``: computed as per sample, once)."""
    sin_tb, reach = k[_K_SIN_TB], k[_K_REACH]
    for j in range(count):
        n, zeta = _coordinates(x[j], dyv, k)
        xi = zeta * sin_tb
        value = _exp(xi * xi / sigma)
        value *= f
        excess[j] = value if abs(xi) < reach else 0.0


@numba.njit(**_JIT)
def _forming_piece(excess, scratch_f, scratch_xi, x, dyv, k, count, saturated, f, sigma):
    """The forming band's values on a piece of a run, saturated or not."""
    if saturated:
        _forming_values_saturated(excess, x, dyv, k, _padded(count), f, sigma)
    else:
        _forming_values(excess, scratch_f, scratch_xi, x, dyv, k, _padded(count))


@numba.njit(**_JIT)
def _forming_add(row, excess, fade, faded, amplitude):
    """row += A·excess (·fade where ``faded``)."""
    for j in range(row.size):
        value = excess[j]
        if faded:
            value *= fade[j]
        row[j] += amplitude * value


@numba.njit(**_JIT)
def _forming_run(row, x, dyv, k, scratch, fade, a, b, f, sigma):
    """The forming band on a run (x coordinates ``x``, padded; faded on its samples a … b − 1
    by ``fade``). The run is split where n crosses the exponent's reach (n is monotone along a
    row, so the samples beyond it lead or trail): f and σ are computed per sample only below
    it. ``scratch``: three rows of space."""
    size = row.size
    reach_n = k[_K_EXP_REACH]
    saturated = 0
    for j in range(size):
        saturated += _coordinates(x[j], dyv, k)[0] >= reach_n
    excess, scratch_f, scratch_xi = scratch[0], scratch[1], scratch[2]
    if saturated == 0 or saturated == size:
        _forming_piece(excess, scratch_f, scratch_xi, x, dyv, k, size, saturated > 0, f, sigma)
    else:
        leading = _coordinates(x[0], dyv, k)[0] >= reach_n
        split = saturated if leading else size - saturated
        _forming_piece(excess, scratch_f, scratch_xi, x, dyv, k, split, leading, f, sigma)
        _forming_piece(excess[split:], scratch_f, scratch_xi, x[split:], dyv, k, size - split,
                       not leading, f, sigma)
    amplitude = k[_K_AMPLITUDE]
    _forming_add(row[:a], excess[:a], fade, False, amplitude)
    _forming_add(row[a:b], excess[a:b], fade, True, amplitude)
    _forming_add(row[b:], excess[b:], fade, False, amplitude)


@numba.njit(**_JIT)
def _surface_span(row, region_row, want_regions, x, dyv, k):
    """The saw-tooth free surface on the samples of ``row``: beyond it, air."""
    d, pitch, min_t, span_t = k[_K_D], k[_K_PITCH], k[_K_MIN_T], k[_K_SPAN_T]
    ambient = k[_K_AMBIENT]
    for j in range(row.size):
        n, zeta = _coordinates(x[j], dyv, k)
        a = (zeta - d) / pitch
        frac = a - np.trunc(a)  # fmod(a, 1) exactly; then numpy.mod's sign rule
        if frac < 0.0:
            frac += 1.0
        if n > min_t + span_t * (1.0 - frac):
            row[j] = ambient
            if want_regions:
                region_row[j] = 0  # REGIONS["air"]


@numba.njit(**_JIT)
def _copy(target, source):
    """target[:] = source (a loop from 0: vectorised, and no call into numpy's copy)."""
    for j in range(target.size):
        target[j] = source[j]


@numba.njit(**_JIT)
def _modulation_span(row, cos_field, sin_field, ca, sa):
    """The travelling modulation on the samples of ``row``."""
    for j in range(row.size):
        row[j] += ca * cos_field[j] + sa * sin_field[j]


@numba.njit(**_JIT)
def _frame_row(i, static, regions_static, out, regions_out, want_regions, forming, x, y, k,
               profile, cos_field, sin_field, ptr, runs, fade, fade_rows, scratch, f_saturated,
               sigma_saturated):
    """Row i of the frame: the static row, then the moving terms on the row's runs
    (``scratch``: three rows of space, padded)."""
    row = out[i]
    _copy(row, static[i])
    region_row = regions_out[0]
    if want_regions:
        region_row = regions_out[i]
        _copy(region_row, regions_static[i])
    dyv = y[i] - k[_K_TIP_Y]
    # Travelling modulation of the secondary zone.
    ca, sa = k[_K_COS], k[_K_SIN]
    for q in range(ptr[_SET_PERIODIC, i], ptr[_SET_PERIODIC, i + 1]):
        j0, j1, at = runs[q, 0], runs[q, 1], runs[q, 2]
        _modulation_span(row[j0:j1], cos_field[at:at + j1 - j0], sin_field[at:at + j1 - j0],
                         ca, sa)
    # The row's faded columns [fade_lo, fade_hi) near the rake face, their fades from
    # fade[f0].
    f0 = fade_rows[i, 0]
    fade_lo = fade_rows[i, 1]
    fade_hi = fade_lo + fade_rows[i + 1, 0] - f0
    # Released bands.
    for q in range(ptr[_SET_CHIP, i], ptr[_SET_CHIP, i + 1]):
        j0, j1 = runs[q, 0], runs[q, 1]
        a = min(max(fade_lo, j0), j1)
        b = min(max(fade_hi, a), j1)
        _chip_span(row[j0:a], x[j0:], dyv, k, profile, fade, False, scratch[0])
        _chip_span(row[a:b], x[a:], dyv, k, profile, fade[f0 + max(a - fade_lo, 0):], True,
                   scratch[0])
        _chip_span(row[b:j1], x[b:], dyv, k, profile, fade, False, scratch[0])
    # The forming band.
    if forming:
        for q in range(ptr[_SET_FORMING, i], ptr[_SET_FORMING, i + 1]):
            j0, j1 = runs[q, 0], runs[q, 1]
            a = min(max(fade_lo, j0), j1)
            b = min(max(fade_hi, a), j1)
            _forming_run(row[j0:j1], x[j0:], dyv, k, scratch, fade[f0 + max(a - fade_lo, 0):],
                         a - j0, b - j0, f_saturated, sigma_saturated)
    # The free surface.
    for q in range(ptr[_SET_SURFACE, i], ptr[_SET_SURFACE, i + 1]):
        j0, j1 = runs[q, 0], runs[q, 1]
        _surface_span(row[j0:j1], region_row[j0:j1] if want_regions else region_row,
                      want_regions, x[j0:], dyv, k)


@numba.njit(**_JIT)
def _band_profile(grid, terms, nodes, sin_b):
    """SegmentedChip._band_profile's arithmetic, with _exp."""
    profile = np.zeros(grid.size)
    for band in range(terms.shape[0]):
        zk, sigma2, amplitude = terms[band, 0], terms[band, 1], terms[band, 2]
        band_profile = profile[nodes[band, 0]:nodes[band, 1]]
        band_grid = grid[nodes[band, 0]:nodes[band, 1]]
        for j in range(band_profile.size):
            dz = (band_grid[j] - zk) * sin_b
            band_profile[j] += amplitude * _exp(-dz * dz / (2 * sigma2))
    return profile


@numba.njit(parallel=True, **_JIT)
def _moving_terms_kernel(threads, bounds, static, regions_static, out, regions_out,
                         want_regions, forming, x, y, k, grid, terms, nodes, cos_field, sin_field,
                         ptr, runs, fade, fade_rows, extremes):
    """The frame over the region: rows bounds[b] … bounds[b + 1] − 1 in block b, the blocks
    dealt to ``threads`` threads in turn (so that each thread's work spans the frame, and the
    threads' shares are even however the blocks' work was estimated). ``out`` (and, with
    ``want_regions``, ``regions_out``) is written in full. ``x`` holds the columns' x
    coordinates and _PAD more (any finite values). The released bands' profile on ``grid`` is
    computed first, from the bands' ``terms`` (ζ_k, σ_k², amplitude) on their ``nodes``.
    ``extremes[thread]``: the least and greatest bit pattern (as int64) of the values the
    thread wrote — as integers, positive finite floats keep their order, and any value ≤ 0 K
    gives one ≤ 0, any +inf or NaN one ≥ that of +inf (the frame's check, in registers)."""
    profile = _band_profile(grid, terms, nodes, k[_K_SIN_TB])
    # f = base^m and σ where the exponent m has saturated at 1 (n beyond its reach), with the
    # arithmetic of _forming_values.
    f_saturated = _exp((k[_K_EXP_TIP] + k[_K_EXP_SLOPE] * 1.0) * k[_K_LOG_BASE])
    sigma_saturated = (1.0 - f_saturated) * (1.0 - f_saturated)
    sigma_saturated *= k[_K_SIGMA_SPAN]
    sigma_saturated += k[_K_SIGMA]
    sigma_saturated *= sigma_saturated
    sigma_saturated *= -2.0
    n_blocks = bounds.size - 1
    for thread in prange(threads):
        scratch = np.empty((3, out.shape[1] + _PAD))
        bits = out.reshape(-1).view(np.int64)
        n_cols = out.shape[1]
        low = np.int64(0x7FFFFFFFFFFFFFFF)
        high = -low
        for b in range(thread, n_blocks, threads):
            for i in range(bounds[b], bounds[b + 1]):
                _frame_row(i, static, regions_static, out, regions_out, want_regions, forming,
                           x, y, k, profile, cos_field, sin_field, ptr, runs, fade, fade_rows,
                           scratch, f_saturated, sigma_saturated)
                for j in range(i * n_cols, (i + 1) * n_cols):
                    v = bits[j]
                    low = v if v < low else low
                    high = v if v > high else high
        extremes[thread, 0] = low
        extremes[thread, 1] = high


@numba.njit(**_JIT)
def _kernel_coordinates(x, y, k):
    """(n, ζ) of every sample of the region as the kernel computes them (for the tests)."""
    n = np.empty((y.size, x.size))
    zeta = np.empty((y.size, x.size))
    for i in range(y.size):
        dyv = y[i] - k[_K_TIP_Y]
        for j in range(x.size):
            n[i, j], zeta[i, j] = _coordinates(x[j], dyv, k)
    return n, zeta


def _runs(flat: np.ndarray, rows: int, cols: int):
    """Row-major flat indices (sorted) as runs of consecutive columns: per-row pointers
    (rows + 1) into the runs, and each run's first column, end column and first position in
    ``flat``."""
    flat = np.asarray(flat, dtype=np.int64)
    if flat.size == 0:
        return np.zeros(rows + 1, dtype=np.int64), np.zeros((0, 3), dtype=np.int64)
    row, col = np.divmod(flat, cols)
    breaks = np.flatnonzero((np.diff(flat) != 1) | (np.diff(row) != 0)) + 1
    first = np.concatenate([[0], breaks])
    last = np.concatenate([breaks, [flat.size]]) - 1
    runs = np.column_stack([col[first], col[last] + 1, first]).astype(np.int64)
    ptr = np.searchsorted(row[first], np.arange(rows + 1)).astype(np.int64)
    return ptr, runs


class _KernelData:
    """The run layout of one region for :func:`_moving_terms_kernel`: each index set of the
    region (_RegionData) as runs of columns per row, the rake-face fade on each row's faded
    columns, the grid constants, and the rows' work for splitting them among threads."""

    def __init__(self, p: ChipParameters, g: _Geometry, region: Region, r: _RegionData):
        rows, cols = r.shape
        sets = [r.periodic, r.chip, np.sort(r.forming), r.surface]
        ptr = np.zeros((len(sets), rows + 1), dtype=np.int64)
        runs = []
        total = 0
        for which, flat in enumerate(sets):
            ptr_s, runs_s = _runs(flat, rows, cols)
            ptr[which] = ptr_s + total
            runs.append(runs_s)
            total += runs_s.shape[0]
        self.ptr = ptr
        self.runs = np.ascontiguousarray(np.concatenate(runs))
        # Faded columns (n < 10 fade lengths) of the chip and forming samples: per row, the
        # span from the first to the last, with the fade where n is below the threshold and 1
        # (an exact no-op) elsewhere, as both the reference's terms have it.
        rs, cs = region
        n_sub = g.n[rs, cs].reshape(-1)
        fade_sub = g.rake_fade[rs, cs].reshape(-1)
        threshold = _FADE_REACH * p.rake_fade
        near = np.zeros(rows * cols, dtype=bool)
        near[r.chip] = near[r.forming] = True
        near = np.flatnonzero(near & (n_sub < threshold))
        fade_rows = np.zeros((rows + 1, 2), dtype=np.int64)
        values = []
        if near.size:
            row_of = near // cols
            starts = np.searchsorted(row_of, np.arange(rows + 1))
            offset = 0
            for i in range(rows):
                fade_rows[i, 0] = offset
                if starts[i + 1] > starts[i]:
                    lo = int(near[starts[i]] - i * cols)
                    hi = int(near[starts[i + 1] - 1] - i * cols) + 1
                    span = slice(i * cols + lo, i * cols + hi)
                    values.append(np.where(n_sub[span] < threshold, fade_sub[span], 1.0))
                    fade_rows[i, 1] = lo
                    offset += hi - lo
            fade_rows[rows, 0] = offset
        self.fade = np.concatenate(values) if values else np.ones(1)
        self.fade_rows = fade_rows
        # Grid constants (the per-frame entries are set by each evaluation).
        k = np.zeros(_K_SIZE)
        a, gamma, tb = p.rake_angle, p.clearance_angle, p.band_angle
        k[_K_TIP_X], k[_K_TIP_Y] = p.tool_tip_x, p.tool_tip_y
        k[_K_SIN_A], k[_K_COS_A] = math.sin(a), math.cos(a)
        k[_K_COS_G], k[_K_SIN_G] = math.cos(gamma), math.sin(gamma)
        k[_K_TAN_TB], k[_K_SIN_TB] = math.tan(tb), math.sin(tb)
        if r.chip.size:
            k[_K_STEP], k[_K_FIRST] = r.zeta_step, r.zeta_first
        k[_K_EXP_TIP] = p.band_exponent_tip
        k[_K_EXP_SLOPE] = 1 - p.band_exponent_tip
        k[_K_EXP_REACH] = p.band_exponent_reach * p.chip_thickness
        k[_K_SIGMA], k[_K_SIGMA_SPAN] = p.band_width, p.band_initial_width - p.band_width
        k[_K_AMPLITUDE] = p.band_amplitude
        k[_K_PITCH], k[_K_AMBIENT] = p.segment_pitch, p.ambient_temperature
        k[_K_MIN_T], k[_K_SPAN_T] = p.min_thickness, p.max_thickness - p.min_thickness
        self.constants = k
        self.x = np.concatenate([r.x, np.full(_PAD, r.x[-1] if r.x.size else 0.0)])  # padded
        # Work per row, summed, for blocks of rows of equal work: relative costs (fitted to
        # timings of row blocks on one core) of a copied sample 1, and of a sample of the
        # modulation 8 (its two fields come from memory), of the released bands 6, of the
        # forming band 6 where its exponent has saturated and 19 elsewhere, of the free surface
        # 2. Two sums: with and without the forming band (absent during the slip).
        def per_row(flat):
            return np.bincount(np.asarray(flat, dtype=np.int64) // cols, minlength=rows)

        forming_n = n_sub[r.forming]
        saturated = r.forming[forming_n >= k[_K_EXP_REACH]]
        free = r.forming[~(forming_n >= k[_K_EXP_REACH])]
        work = (cols + 8 * per_row(r.periodic) + 6 * per_row(r.chip) + 2 * per_row(r.surface))
        forming_work = 6 * per_row(saturated) + 19 * per_row(free)
        self.work = {False: np.concatenate([[0], np.cumsum(work)]),
                     True: np.concatenate([[0], np.cumsum(work + forming_work)])}
        self._bounds: dict[tuple[int, bool], np.ndarray] = {}

    def blocks(self, forming: bool) -> tuple[int, np.ndarray]:
        """The number of threads (numba's, at most one per row) and the row bounds of blocks of
        about equal work, _BLOCKS per thread (with one thread, one block)."""
        work = self.work[forming]
        rows = work.size - 1
        threads = max(1, min(numba.get_num_threads(), rows))
        bounds = self._bounds.get((threads, forming))
        if bounds is None:
            count = max(1, min(threads * _BLOCKS, rows)) if threads > 1 else 1
            inner = np.searchsorted(work, work[-1] * np.arange(1, count) / count)
            bounds = np.concatenate([[0], inner, [rows]]).astype(np.int64)
            self._bounds[threads, forming] = bounds = np.maximum.accumulate(bounds)
        return threads, bounds


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
        given_emissivity = emissivity
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
            for name, value in emissivity.items():
                if isinstance(value, np.ndarray) and value.ndim >= 1:
                    raise RadiosimError(f"emissivity of region {name!r} must be a number or a "
                                        "spectral curve, not a map (a grey map is given for "
                                        "the whole scene: emissivity=map)")
            self._region_emissivity = {name: check_emissivity(emissivity.get(name, 1.0),
                                                               self.shape) for name in REGIONS}
            emissivity = 1.0
        self.emissivity = check_emissivity(emissivity, self.shape)
        self._arguments = (params, dx, dt, given_emissivity, cycles)
        self._geometry = None
        self._regions: dict[tuple, _RegionData] = {}
        self._lock = threading.RLock()
        self._checked_frames = threading.local()  # .last: weakref to a frame known clean

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

    def _evaluate(self, t: float, region: Region, want_regions: bool = False,
                  compiled: bool | None = None):
        """Frame at time t over ``region``: temperature [K] (and, with ``want_regions``, the
        region map). ``compiled`` picks the implementation of the moving terms: the numba
        kernel (True), the numpy reference (False) or, by default, :data:`USE_COMPILED_KERNEL`."""
        if compiled is None:
            compiled = USE_COMPILED_KERNEL
        self._checked_frames.last = None  # only the frame this evaluation makes can be clean
        if compiled:
            return self._evaluate_compiled(t, region, want_regions)
        return self._evaluate_reference(t, region, want_regions)

    def _band_terms(self, r: _RegionData, tau: float, d: float):
        """The released bands, carried with the chip and diffusing: per band k, its ζ_k, σ_k²
        and amplitude, and the range of nodes of the region's ``zeta_grid`` within its reach
        (shared by both implementations)."""
        p = self.params
        sin_b = math.sin(p.band_angle)
        terms = np.empty((int(p.released_bands), 3))
        nodes = np.empty((int(p.released_bands), 2), dtype=np.int64)
        for k in range(int(p.released_bands)):
            zk = d + k * p.segment_pitch
            sigma2 = p.band_width**2 + 2 * p.chip_diffusivity * (tau + k * p.period)
            amplitude = (p.band_amplitude + r.background_at_l0
                         - r.background(zk * sin_b)) * math.sqrt(p.band_width**2 / sigma2)
            reach = _reach(amplitude) * math.sqrt(sigma2) / sin_b
            terms[k] = zk, sigma2, amplitude
            nodes[k] = np.searchsorted(r.zeta_grid, (zk - reach, zk + reach))
        return terms, nodes

    def _band_profile(self, r: _RegionData, tau: float, d: float) -> np.ndarray:
        """The released bands' profile along ζ on the region's ``zeta_grid`` [K]."""
        sin_b = math.sin(self.params.band_angle)
        profile = np.zeros(r.zeta_grid.size)
        for (zk, sigma2, amplitude), (lo, hi) in zip(*self._band_terms(r, tau, d)):
            dz = (r.zeta_grid[lo:hi] - zk) * sin_b
            profile[lo:hi] += amplitude * np.exp(-dz * dz / (2 * sigma2))
        return profile

    def _forming_base(self, theta: float) -> float:
        """The forming band's growth, 0 during the slip, rising to 1 at the end of the cycle."""
        p = self.params
        return min(max((theta - p.slip_time / p.period) / (1 - p.slip_time / p.period), 0.0),
                   1.0)

    def _forming_reach(self, base: float) -> float:
        """|ξ| beyond which the forming band is below 1 mK [m]."""
        p = self.params
        widest = p.band_width + (p.band_initial_width - p.band_width) * (1 - base) ** 2
        return _reach(p.band_amplitude * base) * max(widest, p.band_width)

    def _evaluate_reference(self, t: float, region: Region, want_regions: bool = False):
        """The moving terms in numpy, term by term over their index sets: the reference the
        compiled kernel is tested against (and selected by ``USE_COMPILED_KERNEL = False``)."""
        p, r = self.params, self._prepared(region)
        tau, theta, d = self._phase(t)
        temperature = r.static.copy()
        flat = temperature.reshape(-1)
        # Travelling modulation of the secondary zone (chip and tool) [K].
        angle = 2 * np.pi * (theta - p.modulation_phase)
        flat[r.periodic] += math.cos(angle) * r.cos_field + math.sin(angle) * r.sin_field

        # Released bands, carried with the chip and diffusing: a profile along ζ [K].
        if r.chip.size:
            profile = self._band_profile(r, tau, d)
            left = profile[r.zeta_index]
            excess = left + r.zeta_frac * (profile[r.zeta_index + 1] - left)
            excess[r.chip_faded] *= r.chip_fade
            flat[r.chip] += excess

        # The forming band on L0, on the samples within reach of its current width [K].
        base = self._forming_base(theta)
        if base > 0 and r.forming.size:
            reach = self._forming_reach(base)
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

    def _evaluate_compiled(self, t: float, region: Region, want_regions: bool = False):
        """The moving terms in one fused, row-parallel pass of :func:`_moving_terms_kernel`
        over the region's rows, writing into a fresh copy of the static field (same results as
        :meth:`_evaluate_reference` to rounding; the region map exactly)."""
        p, r = self.params, self._prepared(region)
        with self._lock:
            kd = r.kernel
            if kd is None:
                kd = r.kernel = _KernelData(p, self.geometry, region, r)
        tau, theta, d = self._phase(t)
        angle = 2 * np.pi * (theta - p.modulation_phase)
        base = self._forming_base(theta)
        forming = base > 0 and r.forming.size > 0
        if r.chip.size:
            grid, (terms, nodes) = r.zeta_grid, self._band_terms(r, tau, d)
        else:
            grid, terms, nodes = _NO_PROFILE, _NO_TERMS, _NO_NODES
        frame = np.array(kd.constants)
        frame[_K_COS], frame[_K_SIN] = math.cos(angle), math.sin(angle)
        frame[_K_D] = d
        if forming:
            frame[_K_LOG_BASE] = math.log(base)
            frame[_K_REACH] = self._forming_reach(base)
        temperature = np.empty(r.shape)
        regions = np.empty(r.shape, dtype=np.uint8) if want_regions else _NO_REGIONS
        threads, blocks = kd.blocks(forming)
        extremes = np.empty((threads, 2), dtype=np.int64)
        with parallel_launch():
            _moving_terms_kernel(threads, blocks, r.static, r.regions, temperature, regions,
                                 want_regions, forming, kd.x, r.y, frame, grid, terms, nodes,
                                 r.cos_field, r.sin_field, kd.ptr, kd.runs, kd.fade, kd.fade_rows,
                                 extremes)
        # Every value finite and > 0 K (see _moving_terms_kernel): the frame's check is done.
        clean = temperature.size == 0 or (extremes[:, 0].min() > 0
                                          and extremes[:, 1].max() < _INF_BITS)
        self._checked_frames.last = weakref.ref(temperature) if clean else None
        if not want_regions:
            return temperature
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

    def _checked(self, values, k: int, region: Region) -> np.ndarray:
        """As the scene's check, but the very frame the compiled kernel just made on this
        thread and found clean (finite, > 0 K) is not read again (unless a subclass makes its
        frames another way)."""
        last, self._checked_frames.last = getattr(self._checked_frames, "last", None), None
        if (last is not None and last() is values and type(self)._read is SegmentedChip._read
                and values.dtype == np.float64
                and values.shape == tuple(sl.stop - sl.start for sl in region)):
            return values
        return super()._checked(values, k, region)

    def _sample(self, k: int, region: Region) -> SceneFrame:
        """Temperature and, with an emissivity per region, the region codes of the same
        evaluation."""
        if self._region_emissivity is None:
            return super()._sample(k, region)
        temperature, regions = self._evaluate((k + 0.5) * self.dt, region, want_regions=True)
        return SceneFrame(temperature, 1.0, regions=regions, index=k,
                          region_emissivity={REGIONS[name]: value for name, value
                                             in self._region_emissivity.items()})

    def __reduce__(self):
        """Pickled as its recipe — parameters, grid and environment — never its caches (a
        task on another process rebuilds the geometry it needs)."""
        return (_rebuild_chip, (self._arguments, self.environment))

    def with_emissivity(self, emissivity) -> SegmentedChip:
        """The same chip with grey ``emissivity`` on its metal (workpiece, chip and tool; the
        air keeps its own when the emissivity is given per region)."""
        params, dx, dt, old, cycles = self._arguments
        if isinstance(old, dict):
            emissivity = {**old, **{k: emissivity for k in ("workpiece", "chip", "tool")}}
        return _rebuild_chip((params, dx, dt, emissivity, cycles), self.environment)

    def reflected_field(self, view_length: float = 5e-6,
                        ambient: float | None = None) -> np.ndarray:
        """
        A reflected-temperature map [K] in which chip samples near the rake face see the
        tool's interface temperature (for :meth:`~radiosim.scenes.Scene.set_environment`).

        The approximation: a chip sample at distance n from the rake face and position s along
        it reflects the interface temperature T_face(s) with a weight exp(−n/ℓ), and the
        ambient temperature with the rest, blended in temperature:
        T_refl = T_amb + (T_face(s) − T_amb)·exp(−n/ℓ). A flat side face coplanar with the
        tool's has no view of the rake face at all; the weight stands for the rounded,
        side-flowed edge of a real chip, which does, within a few µm (ℓ) of the contact.
        Everything else reflects the ambient.

        Parameters
        ----------
        view_length
            ℓ [m], the distance from the rake face over which the view of the interface fades.
        ambient
            Ambient temperature [K] (default the chip's ``ambient_temperature``).
        """
        view = check_positive(view_length, "view_length", "m")
        p, g = self.params, self.geometry
        amb = p.ambient_temperature if ambient is None else check_positive(ambient, "ambient",
                                                                           "K")
        face = np.interp(np.clip(g.s, 0.0, None), g.face_s, g.face_temperature)
        weight = np.where(g.chip_max, np.exp(-np.clip(g.n, 0.0, None) / view), 0.0)
        return amb + (face - amb) * weight

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


def _rebuild_chip(arguments, environment) -> SegmentedChip:
    chip = SegmentedChip(*arguments)
    chip.set_environment(**environment)
    return chip

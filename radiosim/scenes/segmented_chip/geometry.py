"""
The segmented chip's geometry on a grid: everything that does not move.

:class:`Geometry` holds a grid's coordinates (along the rake face s, into the chip n, along L0
ζ, across it ξ), its static regions (tool, workpiece, chip up to its thickest free surface), the
static temperature field (the primary zone, the secondary zone's mean, the tool, the
workpiece), the two static fields of the secondary zone's travelling modulation, and the zones
the moving terms can reach. :class:`RegionData` gathers them for one rectangular region, as
flat index sets, so that a frame only touches the samples each moving term can reach.

Coordinates: lab frame x to the right, y up, origin at the bottom-left corner of the field of
view; array row 0 is the top of the field (y = height), as in an image.

References
----------
-   Jaeger, J. C. (1942). Moving sources of heat and the temperature at sliding contacts.
    Proc. R. Soc. N.S.W. 76, 203–224 (the secondary zone, through
    :func:`~radiosim.scenes.segmented_chip.profiles.jaeger_band_source`).
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from scipy.interpolate import RegularGridInterpolator
from scipy.special import erfc

from radiosim.scenes.base import Region
from radiosim.scenes.segmented_chip.parameters import ChipParameters
from radiosim.scenes.segmented_chip.profiles import (
    FADE_REACH,
    NEGLIGIBLE,
    gaussian_reach,
    jaeger_band_source,
    tanh_step,
)

if TYPE_CHECKING:
    from radiosim.scenes.segmented_chip.compiled import KernelLayout

__all__ = ["REGIONS", "COLUMNS", "Geometry", "RegionData", "primary_step_of", "rake_fade_of",
           "band_exponent_of"]

#: Region codes of :meth:`SegmentedChip.regions`.
REGIONS = {"air": 0, "workpiece": 1, "chip": 2, "tool": 3}
#: Reference columns: distance from the rake face, along the shear plane L0, where each
#: vertical column of pixels crosses L0 [m]. Column I is the paper's (near the free surface).
COLUMNS = {"I": 440e-6, "II": 300e-6, "III": 160e-6}


def primary_step_of(p: ChipParameters, xi):
    """The primary zone's step across L0, S((ξ − offset) / width), at signed distances ξ [m]
    from L0 (its rise is ``p.primary_rise`` times this)."""
    return tanh_step((xi - p.primary_offset) / p.primary_width)


def rake_fade_of(p: ChipParameters, n):
    """The bands' fade at the rake face, S(n / ``p.rake_fade``), at distances n [m] into the
    chip."""
    return tanh_step(n / p.rake_fade)


def band_exponent_of(p: ChipParameters, n):
    """The released bands' exponent m(n) at distances n [m] into the chip: ``band_exponent_tip``
    at the rake face, rising linearly to 1 at ``band_exponent_reach`` chip thicknesses."""
    reach_n = p.band_exponent_reach * p.chip_thickness
    return p.band_exponent_tip + (1 - p.band_exponent_tip) * np.clip(n / reach_n, 0.0, 1.0)


class Geometry:
    """Everything about a grid that does not move: coordinates, static fields, masks.

    Each static field is evaluated only on the samples of the region it describes (flat index
    sets), and a quantity of one coordinate only on that row or column, then gathered: the
    same operations per sample as over the whole grid, without its temporaries.
    :attr:`rake_fade` and :attr:`band_exponent` over the whole grid are built on first use
    (:class:`RegionData` evaluates them on its own samples).
    """

    def __init__(self, p: ChipParameters, shape: tuple[int, int], dx: float):
        rows, cols = shape
        self._params = p
        x = (np.arange(cols) + 0.5) * dx
        y = p.field_height - (np.arange(rows) + 0.5) * dx
        dxv = x[None, :] - p.tool_tip_x
        dyv = y[:, None] - p.tool_tip_y
        a, g = p.rake_angle, p.clearance_angle
        s = dxv * math.sin(a) + dyv * math.cos(a)  # along the rake face [m]
        u = dxv * math.cos(g) + dyv * math.sin(g)  # into the tool [m]
        n = -u  # into the chip [m]
        tb = p.band_angle
        zeta = n / math.tan(tb)
        np.subtract(s, zeta, out=zeta)  # s − n/tan θ_b: constant on lines parallel to L0 [m]
        xi = zeta * math.sin(tb)  # signed distance from L0, > 0 in the chip [m]
        self.x, self.y = x, y
        self.s, self.n, self.zeta, self.xi = s, n, zeta, xi

        # Regions that do not move: tool, workpiece; chip up to the thickest free surface.
        # The tool is the quadrant u, s ≥ 0 less its rounded edge: the points of the corner
        # square s, u < r_e outside the circle of radius r_e tangent to both faces.
        re = p.edge_radius
        tool = u >= 0
        tool &= s >= 0
        corner = np.flatnonzero(tool & (s < re) & (u < re))
        s_k, u_k = np.take(s, corner), np.take(u, corner)
        tool.reshape(-1)[corner] = ~((s_k - re) ** 2 + (u_k - re) ** 2 > re**2)
        chip_max = zeta >= 0
        chip_max &= n >= 0
        chip_max &= n <= p.max_thickness
        chip_max &= ~tool
        left = x[None, :] < p.tool_tip_x
        workpiece = np.where(
            left, y[:, None] < p.tool_tip_y + p.uncut_thickness, y[:, None] < p.tool_tip_y)
        workpiece &= ~(tool | chip_max)
        self.tool, self.workpiece, self.chip_max = tool, workpiece, chip_max
        # Each region's samples, as flat indices into the grid.
        in_chip, in_tool, in_work = (np.flatnonzero(m) for m in (chip_max, tool, workpiece))
        self.static_regions = np.full(shape, REGIONS["air"], dtype=np.uint8)
        codes = self.static_regions.reshape(-1)  # flat views are written at flat indices
        codes[in_work], codes[in_tool], codes[in_chip] = (
            REGIONS["workpiece"], REGIONS["tool"], REGIONS["chip"])
        # Where the saw-tooth free surface can lie: chip or air depending on time.
        self.surface_zone = chip_max & (n > p.min_thickness)

        t0 = p.initial_temperature

        def primary(at):
            """The primary zone's rise across L0 at the flat indices ``at`` [K]."""
            return p.primary_rise * primary_step_of(p, np.take(xi, at))

        # Secondary zone (mean field) and the two static fields of its travelling modulation.
        s_chip, n_chip, s_tool = np.take(s, in_chip), np.take(n, in_chip), np.take(s, in_tool)
        step = 0.5e-6
        s_max = max(float(s_chip.max(initial=0.0)), float(s_tool.max(initial=0.0)),
                    p.contact_length) + 2 * step
        n_max = float(n_chip.max(initial=0.0)) + 2 * step
        grid_s, grid_n, jaeger = jaeger_band_source(p, s_max, min(n_max, 400e-6), step)
        lookup = RegularGridInterpolator((grid_n, grid_s), jaeger, bounds_error=False,
                                         fill_value=0.0)
        static = np.full(shape, p.ambient_temperature)
        cos_field = np.zeros(shape)
        sin_field = np.zeros(shape)
        static_, cos_, sin_ = static.reshape(-1), cos_field.reshape(-1), sin_field.reshape(-1)

        # Chip (static part).
        secondary = p.secondary_rise * lookup(np.column_stack(
            [n_chip, np.clip(s_chip, 0.0, None)]))
        static_[in_chip] = t0 + primary(in_chip) + secondary
        phase = 2 * np.pi * s_chip / p.segment_pitch
        amplitude = p.modulation * secondary
        cos_[in_chip] = amplitude * np.cos(phase)
        sin_[in_chip] = amplitude * np.sin(phase)

        # Tool: the rake-face interface temperature conducted in (erfc) and its periodic part.
        s_t, depth = np.clip(s_tool, 0.0, None), np.clip(np.take(u, in_tool), 0.0, None)
        interface_s = np.minimum(s_t, p.contact_length)
        beyond = erfc(np.clip(s_t - p.contact_length, 0.0, None) / p.tool_conduction_length)
        xi_face = interface_s * math.sin(tb)  # on the rake face, n = 0
        face_primary = p.primary_rise * primary_step_of(p, xi_face)
        face_secondary = p.secondary_rise * lookup(np.column_stack(
            [np.zeros_like(interface_s), interface_s]))
        static_[in_tool] = t0 + (face_primary + face_secondary) * beyond * erfc(
            depth / p.tool_conduction_length)
        periodic = p.modulation * face_secondary * beyond * np.exp(-depth / p.tool_periodic_depth)
        phase = 2 * np.pi * s_tool / p.segment_pitch
        cos_[in_tool] = periodic * np.cos(phase)
        sin_[in_tool] = periodic * np.sin(phase)
        # The interface temperature along the rake face (n = u = 0), for the reflected field.
        self.face_s = np.arange(0.0, s_max + step, step)
        on_face = np.minimum(self.face_s, p.contact_length)
        self.face_temperature = t0 + (
            p.primary_rise * primary_step_of(p, on_face * math.sin(tb))
            + p.secondary_rise * lookup(np.column_stack([np.zeros_like(on_face), on_face]))
        ) * erfc(np.clip(self.face_s - p.contact_length, 0.0, None) / p.tool_conduction_length)

        # Workpiece: primary-zone step ahead of the tool, faded behind the tip, and the
        # machined-surface layer broadening with the time since it was cut. The fade and the
        # layer's width depend on the column only, its depth on the row only.
        col = in_work % cols
        behind = np.clip(x - p.tool_tip_x, 0.0, None)
        fade = np.exp(-behind / p.primary_width)
        sigma2 = p.surface_width**2 + 2 * p.workpiece_diffusivity * behind / p.cutting_speed
        below = np.clip(p.tool_tip_y - y, 0.0, None)
        layer = np.zeros(in_work.size)  # 0 ahead of the tip
        cut = np.flatnonzero((x >= p.tool_tip_x)[col])  # behind the tip
        row_c, col_c = in_work[cut] // cols, col[cut]
        layer[cut] = (p.surface_rise * np.sqrt(p.surface_width**2 / sigma2))[col_c] * np.exp(
            (-below**2)[row_c] / (2 * sigma2)[col_c])
        static_[in_work] = t0 + primary(in_work) * fade[col] + layer

        self.static = static
        self.cos_field, self.sin_field = cos_field, sin_field
        # Band terms reach the chip and, for the forming band, the workpiece near L0.
        reach = gaussian_reach(p.band_amplitude) * max(p.band_initial_width, p.band_width)
        forming_zone = workpiece & left
        forming_zone |= chip_max
        forming_zone &= np.abs(xi) < reach
        self.forming_zone = forming_zone

    @cached_property
    def rake_fade(self) -> np.ndarray:
        """The bands' fade at the rake face over the grid (:func:`rake_fade_of`; built on first
        use)."""
        return rake_fade_of(self._params, self.n)

    @cached_property
    def band_exponent(self) -> np.ndarray:
        """The released bands' exponent over the grid (:func:`band_exponent_of`; built on first
        use)."""
        return band_exponent_of(self._params, self.n)


class RegionData:
    """The static data of one rectangular region, as flat index sets and gathered values, so
    that a frame only touches the samples each moving term can reach."""

    def __init__(self, p: ChipParameters, g: Geometry, region: Region):
        rs, cs = region

        def sub(a):
            return np.ascontiguousarray(a[rs, cs]).reshape(-1)

        self.static = np.ascontiguousarray(g.static[rs, cs])
        self.regions = np.ascontiguousarray(g.static_regions[rs, cs])
        cos_field, sin_field = sub(g.cos_field), sub(g.sin_field)
        # The modulation's amplitude dies away from the rake face: drop it below 1 mK. It is
        # zero outside the chip and the tool.
        codes = self.regions.reshape(-1)
        hot = np.flatnonzero((codes == REGIONS["chip"]) | (codes == REGIONS["tool"]))
        self.periodic = hot[np.hypot(cos_field[hot], sin_field[hot]) > NEGLIGIBLE]
        self.cos_field, self.sin_field = cos_field[self.periodic], sin_field[self.periodic]
        zeta, n_all = sub(g.zeta), sub(g.n)
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
            n_chip = n_all[self.chip]
            self.chip_faded = np.flatnonzero(n_chip < FADE_REACH * p.rake_fade)
            self.chip_fade = rake_fade_of(p, n_chip[self.chip_faded])
        forming = np.flatnonzero(sub(g.forming_zone))
        xi = sub(g.xi)[forming]
        order = np.argsort(np.abs(xi), kind="stable")
        self.forming = forming[order]
        self.forming_abs_xi = np.abs(xi[order])
        self.forming_xi2 = xi[order] ** 2
        n_forming = n_all[self.forming]
        self.forming_exponent = band_exponent_of(p, n_forming)
        self.forming_faded = n_forming < FADE_REACH * p.rake_fade
        self.forming_fade = np.ones(self.forming.size)
        self.forming_fade[self.forming_faded] = rake_fade_of(p, n_forming[self.forming_faded])
        self.surface = np.flatnonzero(sub(g.surface_zone))
        self.surface_zeta = zeta[self.surface]
        self.surface_n = n_all[self.surface]
        t0, rise = p.initial_temperature, p.primary_rise
        self.background = lambda xi_: t0 + rise * float(primary_step_of(p, xi_))
        self.background_at_l0 = self.background(0.0)
        # For the compiled kernel: the region's place in the grid and its coordinates, and its
        # run layout (built on its first compiled evaluation, see KernelLayout).
        self.shape = self.static.shape
        self.x, self.y = g.x[cs], g.y[rs]
        self.kernel: KernelLayout | None = None

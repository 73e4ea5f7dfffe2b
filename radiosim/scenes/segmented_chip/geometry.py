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

__all__ = ["REGIONS", "COLUMNS", "Geometry", "RegionData"]

#: Region codes of :meth:`SegmentedChip.regions`.
REGIONS = {"air": 0, "workpiece": 1, "chip": 2, "tool": 3}
#: Reference columns: distance from the rake face, along the shear plane L0, where each
#: vertical column of pixels crosses L0 [m]. Column I is the paper's (near the free surface).
COLUMNS = {"I": 440e-6, "II": 300e-6, "III": 160e-6}


class Geometry:
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
        primary = p.primary_rise * tanh_step((xi - p.primary_offset) / p.primary_width)

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
        face_primary = p.primary_rise * tanh_step((xi_face - p.primary_offset)
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
            p.primary_rise * tanh_step((on_face * math.sin(tb) - p.primary_offset)
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
        reach = gaussian_reach(p.band_amplitude) * max(p.band_initial_width, p.band_width)
        self.forming_zone = (chip_max | (workpiece & left)) & (np.abs(xi) < reach)
        self.rake_fade = tanh_step(n / p.rake_fade)
        reach_n = p.band_exponent_reach * p.chip_thickness
        self.band_exponent = p.band_exponent_tip + (1 - p.band_exponent_tip) * np.clip(
            n / reach_n, 0.0, 1.0)


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
        # The modulation's amplitude dies away from the rake face: drop it below 1 mK.
        self.periodic = np.flatnonzero(np.hypot(cos_field, sin_field) > NEGLIGIBLE)
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
            self.chip_faded = np.flatnonzero(n_all[self.chip] < FADE_REACH * p.rake_fade)
            self.chip_fade = fade[self.chip][self.chip_faded]
        forming = np.flatnonzero(sub(g.forming_zone))
        xi = sub(g.xi)[forming]
        order = np.argsort(np.abs(xi), kind="stable")
        self.forming = forming[order]
        self.forming_abs_xi = np.abs(xi[order])
        self.forming_xi2 = xi[order] ** 2
        self.forming_exponent = sub(g.band_exponent)[self.forming]
        self.forming_faded = n_all[self.forming] < FADE_REACH * p.rake_fade
        self.forming_fade = np.where(self.forming_faded, fade[self.forming], 1.0)
        self.surface = np.flatnonzero(sub(g.surface_zone))
        self.surface_zeta = zeta[self.surface]
        self.surface_n = sub(g.n)[self.surface]
        t0, rise = p.initial_temperature, p.primary_rise
        self.background = lambda xi_: t0 + rise * float(
            tanh_step((xi_ - p.primary_offset) / p.primary_width))
        self.background_at_l0 = self.background(0.0)
        # For the compiled kernel: the region's place in the grid and its coordinates, and its
        # run layout (built on its first compiled evaluation, see KernelLayout).
        self.shape = self.static.shape
        self.x, self.y = g.x[cs], g.y[rs]
        self.kernel: KernelLayout | None = None

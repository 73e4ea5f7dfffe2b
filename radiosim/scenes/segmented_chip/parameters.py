"""
Parameters of the segmented-chip scene: :class:`ChipParameters`, in SI units, with their TOML
keys (units in the keys) and the quantities derived from them (chip speed and thickness,
segment pitch, shear angle, band angle, the saw-tooth's thicknesses).

The specification is ``docs/scene.md`` (its table of parameters lists every TOML key).

References
----------
-   Merchant, M. E. (1945) and Lee & Shaffer (1951) for the shear-angle relation
    tan φ = r cos α / (1 − r sin α) (:attr:`ChipParameters.shear_angle`).
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass

from radiosim.config import build_from_toml, dumps_toml, edge_field, from_table, to_table
from radiosim.errors import RadiosimError
from radiosim.files import write_text
from radiosim.checks import check_count
from radiosim.units import AMBIENT_TEMPERATURE, CELSIUS_OFFSET, MICRO

__all__ = ["ChipParameters"]

#: µm² per µs in SI: 1e-12 m² / 1e-6 s [m² s⁻¹] (the diffusivities' TOML unit).
_UM2_PER_US = MICRO


def _param(default, toml_key, scale=1.0, offset=0.0, doc=""):
    """A parameter with its TOML key (edge units) and conversion: SI = value·scale + offset."""
    return edge_field(default, toml_key, scale, offset, doc,
                      kind="int" if isinstance(default, int) else "number")


@dataclass(frozen=True)
class ChipParameters:
    """
    Parameters of the segmented-chip scene, in SI units (K, m, s, rad).

    TOML files use the units of ``docs/scene.md`` with the unit in each key (``period_us``,
    ``band_width_um``, ``initial_temperature_C``); :meth:`from_toml` and :meth:`to_toml`
    convert. The defaults are the specification's first values except the eight that
    :func:`radiosim.paper.chip_calibration.calibrate` fitted to the paper's figures
    (slip fraction, primary rise, band amplitude, widths and diffusivity, secondary rise,
    modulation); docs/scene.md gives both, the fit and its result.
    """

    # Process and frame
    cutting_speed: float = _param(250 / 60, "cutting_speed_m_per_min", 1 / 60,
                                  doc="workpiece speed V [m/s]")
    uncut_thickness: float = _param(300e-6, "uncut_thickness_um", MICRO, doc="h [m]")
    initial_temperature: float = _param(AMBIENT_TEMPERATURE, "initial_temperature_C", 1.0,
                                        CELSIUS_OFFSET, doc="T₀ [K]")
    ambient_temperature: float = _param(AMBIENT_TEMPERATURE, "ambient_temperature_C", 1.0,
                                        CELSIUS_OFFSET, doc="air [K]")
    rake_angle: float = _param(math.radians(-7), "rake_angle_deg", math.pi / 180, doc="α [rad]")
    clearance_angle: float = _param(math.radians(7), "clearance_angle_deg", math.pi / 180,
                                    doc="γ [rad]")
    edge_radius: float = _param(20e-6, "edge_radius_um", MICRO, doc="r_e [m]")
    field_width: float = _param(960e-6, "field_width_um", MICRO, doc="width of the field of view [m]")
    field_height: float = _param(742e-6, "field_height_um", MICRO,
                                 doc="height of the field of view [m]")
    tool_tip_x: float = _param(700e-6, "tool_tip_x_um", MICRO, doc="tool tip x [m]")
    tool_tip_y: float = _param(250e-6, "tool_tip_y_um", MICRO, doc="tool tip y [m]")
    # Segmentation
    period: float = _param(90e-6, "period_us", MICRO, doc="segmentation period P [s]")
    chip_ratio: float = _param(0.55, "chip_ratio", doc="r = h/h_c")
    segmentation_degree: float = _param(0.23, "segmentation_degree", doc="G_s")
    slip_fraction: float = _param(0.5026, "slip_fraction", doc="ε of the stick–slip")
    slip_time: float = _param(6e-6, "slip_time_us", MICRO, doc="τ_s [s]")
    # Primary zone
    primary_rise: float = _param(213.1, "primary_rise_K", doc="ΔT_p [K]")
    primary_width: float = _param(12e-6, "primary_width_um", MICRO, doc="w_p [m]")
    primary_offset: float = _param(-1.5e-6, "primary_offset_um", MICRO, doc="ξ_off [m]")
    # Shear bands
    band_amplitude: float = _param(408.3, "band_amplitude_K", doc="A [K]")
    band_width: float = _param(16.27e-6, "band_width_um", MICRO, doc="σ_rel [m]")
    band_initial_width: float = _param(21.07e-6, "band_initial_width_um", MICRO, doc="σ_init [m]")
    band_exponent_tip: float = _param(0.35, "band_exponent_tip", doc="m at the tool tip")
    band_exponent_reach: float = _param(0.6, "band_exponent_reach",
                                        doc="m reaches 1 at this fraction of h_c")
    chip_diffusivity: float = _param(4.635e-6, "chip_diffusivity_um2_per_us", _UM2_PER_US,
                                     doc="a_c [m²/s]")
    released_bands: int = _param(6, "released_bands", doc="bands k = 0 … N−1")
    rake_fade: float = _param(2e-6, "rake_fade_um", MICRO, doc="band fade at the rake face [m]")
    # Secondary (friction) zone
    secondary_rise: float = _param(343.4, "secondary_rise_K", doc="ΔT_s [K]")
    contact_length: float = _param(450e-6, "contact_length_um", MICRO, doc="L_c [m]")
    full_flux_fraction: float = _param(0.55, "full_flux_fraction", doc="q = 1 up to this × L_c")
    secondary_diffusivity: float = _param(6.5e-6, "secondary_diffusivity_um2_per_us", _UM2_PER_US,
                                          doc="a_s [m²/s]")
    tool_sink: float = _param(0.2, "tool_sink", doc="κ")
    tool_sink_depth: float = _param(4e-6, "tool_sink_depth_um", MICRO, doc="λ [m]")
    modulation: float = _param(0.2645, "modulation", doc="a")
    modulation_phase: float = _param(0.10, "modulation_phase", doc="θ_m")
    # Tool and workpiece
    tool_conduction_length: float = _param(100e-6, "tool_conduction_length_um", MICRO,
                                           doc="L_t [m]")
    tool_periodic_depth: float = _param(25e-6, "tool_periodic_depth_um", MICRO, doc="δ_ω [m]")
    surface_rise: float = _param(200.0, "surface_rise_K", doc="A_ms [K]")
    surface_width: float = _param(5e-6, "surface_width_um", MICRO, doc="σ₀ [m]")
    workpiece_diffusivity: float = _param(11e-6, "workpiece_diffusivity_um2_per_us", _UM2_PER_US,
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
        check_count(self.released_bands, "released_bands")

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


"""
Reports of the laboratory commands: what ``radiosim uncertainty``, ``report``, ``sse`` and
``calibrate`` write (CSV tables and figures) and the plain-text tables they print.

Each writer takes the result the library computed (an uncertainty evaluation, a datasheet, a
size-of-source curve, a calibration fit) and a folder or path; the text functions return lines
(the command prints them: the library never prints). Temperatures in tables are °C where a
reader compares them with a scene, kelvin where they are calibration points, as the column
headers say.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from radiosim.files import write_text
from radiosim.plotting import figure, save_figure
from radiosim.units import to_celsius, typed

__all__ = ["measurement_lines", "under_range_lines", "is_bad_sample", "bad_sample_in",
           "catalogue_lines", "BUDGET_COLUMNS", "budget_csv", "write_budget", "budget_lines",
           "DATASHEET_FIGURES", "write_datasheet", "datasheet_lines", "sse_csv", "sse_lines",
           "calibration_lines"]

#: The columns of budget.csv.
BUDGET_COLUMNS = ("quantity", "input", "distribution", "unit", "estimate", "std_uncertainty",
                  "sensitivity", "gum_contribution_K", "mc_contribution_K", "share_percent")


# -- one measurement, and the shipped cameras and studies ---------------------------------------


def measurement_lines(m, summary: dict) -> list[str]:
    """A :class:`~radiosim.measurement.Measurement` in two lines: the camera, its pixels and
    window; the scene's peak, the highest reading with its bias and ±1σ, and the flagged
    fractions. ``summary``: :func:`radiosim.study.summarise` of ``m``."""
    if math.isnan(summary["peak_C"]):  # every pixel flagged: no reading to print
        reading = "no reading (every pixel flagged)"
    else:
        reading = (f"{summary['peak_C']:.1f} °C (bias {summary['peak_bias_K']:+.1f} K, ±1σ "
                   f"{summary['peak_uncertainty_K']:.1f} K)")
    return [f"{m.camera.name}: {m.shape[1]} × {m.shape[0]} pixels, "
            f"{m.integration_time * 1e6:g} µs from {m.t_start * 1e6:g} µs ({m.n_frames} frames)",
            f"  scene peak {summary['peak_scene_C']:.1f} °C; highest reading {reading}; "
            f"saturated {100 * m.saturated_fraction:.1f} %, under range "
            f"{100 * summary['under_range_fraction']:.1f} %, over range "
            f"{100 * summary['over_range_fraction']:.1f} %"]


def under_range_lines(camera, integration_time, peak_scene_C: float,
                      measurement=None) -> list[str]:
    """Why a measurement read nothing, naming the cause that holds: the scene's peak [°C]
    below ``camera``'s lowest measurable temperature at ``integration_time`` [s, or a
    quantity as typed], and whether that limit is the detection limit (counts within
    ``detection_sigma`` σ of the blank reading) or the start of the calibration range. A
    camera of several channels gets a line per channel and, from ``measurement`` (its
    :class:`~radiosim.measurement.Measurement`), how many pixels each cause flags: a channel
    under range, a ratio outside the ratio curve (the assumed emissivity ratio stated), a
    ratio too noisy."""
    t = float(integration_time)
    if camera.channels is None:
        return [f"  every pixel is under range: the scene's peak {peak_scene_C:.1f} °C is below "
                f"{camera.name}'s lowest measurable temperature at {typed(integration_time)} "
                f"({_lowest_text(camera, t)})"]
    lines = [f"  every pixel is under range: the scene's peak {peak_scene_C:.1f} °C; "
             f"{camera.name} reads a ratio where each of its channels reads:"]
    channels = getattr(measurement, "channels", None) or ()
    for k, own in enumerate(camera.channel_cameras):
        lo, hi = camera.channels[k].band
        flagged = (f"; {int(channels[k].under_range.sum())} of {channels[k].under_range.size} "
                   "pixels under range" if k < len(channels) else "")
        lines.append(f"    channel {k} ({lo * 1e6:g}–{hi * 1e6:g} µm): lowest measurable "
                     f"temperature {_lowest_text(own, t)}{flagged}")
    if len(channels) >= 2:
        both = ~channels[0].under_range & ~channels[1].under_range
        flags = ~measurement.saturated & measurement.under_range & both
        if flags.any():
            lines.append(
                f"    {int(flags.sum())} pixels read in both channels but their ratio (divided "
                f"by the assumed emissivity ratio {camera.assumed_emissivity_ratio:g}) lies "
                "outside the ratio curve's calibration range or is noisier than "
                f"ratio_noise_limit {camera.ratio_noise_limit}: is the emissivity ratio right?")
    return lines


def _lowest_text(camera, integration_time: float) -> str:
    """The lowest measurable temperature in °C and what sets it: the detection limit or the
    calibration range's start."""
    calibration = camera.calibration(integration_time)
    low = calibration.lowest_measurable_temperature()
    if math.isnan(low):
        return ("nothing: no temperature of the calibration range reaches "
                f"{camera.detection_sigma:g} σ above the blank reading")
    start = calibration.temperature_range[0]
    if low == start and float(calibration.counts(start)) > calibration.detection_limit_counts:
        return (f"{to_celsius(low):.1f} °C: the calibration range starts there "
                f"(calibration_range_K from {start:g} K); the detection limit alone would "
                "reach lower")
    return (f"{to_celsius(low):.1f} °C: below it the counts lie within "
            f"{camera.detection_sigma:g} σ of the blank reading")


#: The reader's message for a bad temperature sample (radiosim.checks.bad_sample_message).
_BAD_SAMPLE = re.compile(
    r"frame \d+: temperature at row \d+, column \d+ is (?P<value>\S+) K; temperatures must "
    r"be > 0 K \(°C passed as kelvin\?\)|frame \d+: temperature at row")


def is_bad_sample(message: str) -> bool:
    """Whether ``message`` is a reader's refusal of a bad temperature sample (the file's
    fault, not the window's)."""
    return _BAD_SAMPLE.match(message) is not None


def bad_sample_in(message: str, units: str | None) -> str:
    """A bad-sample message in the unit of the file: for ``units`` ``"C"`` the value in °C
    (and the limit, absolute zero); otherwise as it is."""
    match = _BAD_SAMPLE.match(message)
    if units != "C" or match is None or match.group("value") is None:
        return message
    kelvin = float(match.group("value"))
    return message.replace(
        f"is {match.group('value')} K; temperatures must be > 0 K (°C passed as kelvin?)",
        f"is {to_celsius(kelvin):g} °C ({kelvin:g} K); temperatures must be above absolute "
        "zero (-273.15 °C)")


def catalogue_lines() -> list[str]:
    """The shipped cameras (name, response, array, object pixel, band) and studies (name,
    description), as ``radiosim presets`` lists them."""
    import tomllib

    from radiosim.camera import PRESET_DIRECTORY, Camera, available_presets
    from radiosim.study import Study, available_studies

    lines = ["cameras (radiosim measure --camera NAME):",
             f"  {'linear-ideal':<14} linear  the paper's ideal camera (any pixel pitch)"]
    for name in available_presets():
        camera = Camera.preset(name)
        rows, cols = camera.fpa.shape or ("-", "-")
        bands = [c.band for c in camera.channels] if camera.channels else [camera.optics.band]
        lines.append(f"  {name:<14} {camera.response:<7} {cols} x {rows} px, "
                     f"{camera.fpa.pixel_pitch * 1e6:g} µm object pixel, "
                     + " + ".join(f"{lo * 1e6:g}-{hi * 1e6:g} µm" for lo, hi in bands))
        with open(PRESET_DIRECTORY / f"{name}.toml", "rb") as file:  # what sets it apart
            description = tomllib.load(file).get("description")
        if description:
            lines.append(f"  {'':<14} {description}")
    lines.append("studies (radiosim run NAME):")
    lines += [f"  {name:<14} {Study.preset(name).description}" for name in available_studies()]
    return lines


# -- the uncertainty budget ---------------------------------------------------------------------


def budget_csv(result) -> str:
    """The budget of an uncertainty evaluation (:class:`~radiosim.uncertainty.UncertaintyResult`)
    as CSV text, :data:`BUDGET_COLUMNS`, numbers to 6 significant digits."""
    import csv
    import io

    text = io.StringIO()
    writer = csv.DictWriter(text, BUDGET_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k])
                      for k in BUDGET_COLUMNS} for r in result.budget)
    return text.getvalue()


def write_budget(folder, result, name: str, camera, integration_time: float) -> list[Path]:
    """
    Write an uncertainty evaluation into ``folder``: budget.csv (:func:`budget_csv`),
    uncertainty.exr (the per-pixel mean, standard uncertainty and interval,
    :func:`radiosim.io.exr.write_uncertainty_exr`, with ``camera`` and ``integration_time``
    [s]) and budget.png (the map of u(T_app) and each input's contribution to the peak
    reading's uncertainty, GUM and one at a time). ``name``: the study's, in the title.
    """
    from radiosim.io.exr import write_uncertainty_exr

    folder = Path(folder)
    written = [write_text(folder / "budget.csv", budget_csv(result))]
    write_uncertainty_exr(folder / "uncertainty.exr", result, camera, integration_time)
    written.append(folder / "uncertainty.exr")
    fig = figure(10, 4)
    ax1, ax2 = fig.subplots(1, 2)
    rows, cols = np.shape(result.std)
    pitch = camera.fpa.pixel_pitch * 1e6  # [µm] in object space: the map's scale
    # Row 0 at the top, y up from the bottom row: the scene's axes (and its figures').
    image = ax1.imshow(result.std, cmap="viridis", extent=(0, cols * pitch, 0, rows * pitch))
    fig.colorbar(image, ax=ax1, label="standard uncertainty [K]")
    ax1.set_title(f"{name}: u(T_app), {result.draws} draws")
    ax1.set(xlabel="x [µm, object space]", ylabel="y [µm]")
    peak = [r for r in result.budget if r["quantity"] == "peak"]
    ax2.barh([r["input"] for r in peak], [r["gum_contribution_K"] for r in peak], label="GUM")
    ax2.barh([r["input"] for r in peak], [r["mc_contribution_K"] for r in peak],
             height=0.4, label="one at a time (MC)")
    ax2.set_xlabel("contribution to u(peak reading) [K]")
    ax2.legend()
    written.append(save_figure(fig, folder / "budget.png"))
    return written


def budget_lines(result) -> list[str]:
    """The peak reading's budget as a text table (input, u(x), GUM and Monte Carlo
    contributions [K], share), then the peak pixel's reading, u and 95 % interval [°C]."""
    from radiosim.uncertainty import INPUTS

    lines = [f"{'input':<24}{'u(x)':>18}{'GUM [K]':>10}{'MC [K]':>10}{'share':>8}"]
    for r in (r for r in result.budget if r["quantity"] == "peak"):
        record = INPUTS.get(r["input"])
        if record is None or not math.isfinite(r["std_uncertainty"]):  # the temporal noise
            u = "—"
        else:  # in the unit the study file states it (µm, µs, K, or none)
            unit = "" if record.unit == "1" else f" {record.edge_unit}"
            u = f"{r['std_uncertainty'] / record.scale:.4g}{unit}"
        lines.append(f"{r['input']:<24}{u:>18}"
                     f"{r['gum_contribution_K']:>10.3g}{r['mc_contribution_K']:>10.3g}"
                     f"{r['share_percent']:>7.1f}%")
    low, high = result.interval(0.95)
    i = np.unravel_index(np.nanargmax(result.mean), result.mean.shape)
    lines.append(f"peak pixel {tuple(int(v) for v in i)}: {to_celsius(result.mean[i]):.1f} °C, "
                 f"u = {result.std[i]:.2f} K, 95 % [{to_celsius(low[i]):.1f}, "
                 f"{to_celsius(high[i]):.1f}] °C, scene {to_celsius(result.truth[i]):.1f} °C")
    return lines


# -- the datasheet ------------------------------------------------------------------------------

#: The datasheet's figures, in the order :meth:`~radiosim.characterization.Datasheet.draw`
#: fills its axes.
DATASHEET_FIGURES = ("photon_transfer", "netd", "range")


def write_datasheet(folder, sheet, camera, integration_time: float) -> list[Path]:
    """Write a :class:`~radiosim.characterization.Datasheet` of ``camera`` at
    ``integration_time`` [s] into ``folder``: datasheet.csv and one PNG per
    :data:`DATASHEET_FIGURES` (saturation drawn up to the camera's calibration range)."""
    folder = Path(folder)
    written = [write_text(folder / "datasheet.csv", sheet.csv_text())]
    figures = [figure(6, 4) for _ in DATASHEET_FIGURES]
    sheet.draw([fig.add_subplot() for fig in figures], camera.name, integration_time,
               camera.calibration_range[1])
    for fig, name in zip(figures, DATASHEET_FIGURES):
        written.append(save_figure(fig, folder / f"{name}.png"))
    return written


def datasheet_lines(sheet, rows: int = 6) -> list[str]:
    """The datasheet's first ``rows`` rows (the EMVA 1288 quantities) as text lines."""
    return [f"  {r['quantity']:<22}{r['value']:>12.4g} {r['unit']:<6} ({r['condition']})"
            for r in sheet.rows[:rows]]


# -- the size-of-source curve -------------------------------------------------------------------


def sse_csv(curve) -> str:
    """A :class:`~radiosim.characterization.SizeOfSource` curve as CSV text: diameter [µm],
    signal [response unit], SSE [1], the centre pixel's reading [°C]."""
    lines = ["diameter_um,signal,sse,apparent_C"]
    for d, sig, sse, t in zip(curve.diameter, curve.signal, curve.sse,
                              curve.apparent_temperature):
        lines.append(f"{d * 1e6:.6g},{sig:.10g},{sse:.10g},{to_celsius(t):.6g}")
    return "\n".join(lines) + "\n"


def sse_lines(curve, halo=None) -> list[str]:
    """The curve as a text table (diameter [µm], SSE [1], reading [°C]) and, with ``halo``
    (a :class:`~radiosim.characterization.HaloFit`), the fitted effective halo."""
    lines = [f"{'diameter':>10}{'SSE':>10}{'reading':>10}", f"{'[µm]':>10}{'[1]':>10}{'[°C]':>10}"]
    lines += [f"{d * 1e6:>10.1f}{sse:>10.5f}{to_celsius(t):>10.1f}"
              for d, sse, t in zip(curve.diameter, curve.sse, curve.apparent_temperature)]
    if halo is not None:
        lines.append(f"effective halo fitted to the discs ≥ 10 pixels (diffraction's own r⁻³ "
                     f"wings included): fraction {halo.halo.fraction:.4g}, width "
                     f"{halo.halo.width * 1e6:.4g} µm (rms residual "
                     f"{np.sqrt(np.mean(halo.residuals**2)):.2g})")
    return lines


# -- a calibration fit --------------------------------------------------------------------------


def calibration_lines(camera, fitted, table, residuals, source: str,
                      integration_time: float) -> list[str]:
    """What a calibration fit found (:func:`radiosim.calibration_table.calibrate_from_table`):
    the fitted gain [DN/e⁻] and offset [DN] against ``camera``'s (and the optics' emissivity
    when the table gives instrument temperatures), then each point's temperature [K], counts
    [DN] and residual [DN] (``excluded`` where it was left out). ``source``: the table's
    name; ``integration_time`` [s]."""
    el = fitted.electronics
    lines = [f"{camera.name} fitted to {source} ({len(table.temperature)} points, "
             f"{integration_time * 1e6:g} µs): gain {el.gain:.6g} DN/e⁻ (was "
             f"{camera.electronics.gain:.6g}), offset {el.offset:.6g} DN (was "
             f"{camera.electronics.offset:.6g})"
             + (f", instrument factor {fitted.optics.instrument_factor:.4g}"
                if table.instrument_temperature is not None else ""),
             f"{'T [K]':>10}{'counts':>12}{'residual':>10}"]
    lines += [f"{t:>10.2f}{c:>12.1f}" + (f"{'excluded':>10}" if math.isnan(r) else f"{r:>10.2f}")
              for t, c, r in zip(table.temperature, table.counts, residuals)]
    return lines

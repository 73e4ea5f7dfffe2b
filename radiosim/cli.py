"""
The ``radiosim`` command.

``radiosim run [STUDY]`` runs a study (the paper's by default) into a folder of results.csv, EXR
files and figures; ``radiosim measure`` measures one scene file with one camera;
``radiosim presets`` lists cameras and studies; ``radiosim scene preview`` draws the built-in
scene like the paper's Figure 4. Options take human units (``10us``, ``6um``, ``739C``).
The command owns all console output; the library only logs and warns.

One error boundary (:func:`main`): a mistake in the input (a :class:`RadiosimError`, a bad
option) prints one line on stderr and exits with 2; a failure while running (an ``OSError``
such as a full disk) exits with 1; Ctrl-C or SIGTERM exits with 130, leaving no temporary file.
``--debug`` shows the traceback instead. The arguments are checked before any work by
:mod:`radiosim.cli_checks`.
"""

from __future__ import annotations

import argparse
import gc
import logging
import os
import shlex
import signal
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

# radiosim.cli_signals first: in the command's process it installs the start-up signal handlers
# (one line and exit 130 on Ctrl-C or SIGTERM while the heavy modules load).
from radiosim.cli_signals import (bad_mplbackend as _bad_mplbackend,
                                  damaged_cache as _damaged_cache,
                                  encode_what_it_can as _encode_what_it_can,
                                  exit_done as _exit_done, exit_interrupted as _exit_now,
                                  on_interrupt as _interrupt, on_unraisable as _on_unraisable,
                                  short_of_memory as _short_of_memory)
from radiosim.errors import Interrupted, RadiosimError, RadiosimIOError, RadiosimWarning
from radiosim.interrupts import command_state as _Command
from radiosim import __version__  # noqa: E402
from radiosim.console import (Progress as _Progress, outlive_the_reader as _outlive_the_reader,
                              show_warning as _show_warning, shell_expanded as _unexpanded)
from radiosim.cli_checks import (camera_from_argument as _camera,
                                  check_frame_period_option as _check_frame_period,
                                  check_out_file as _check_out_file, check_scale as _check_scale,
                                  check_scheduler as _check_scheduler, from_file as _from_file,
                                  scene_refusal as _scene_refusal)
from radiosim.units import (AMBIENT_TEMPERATURE, join_negatives as _join_negatives,
                            parse_length, parse_temperature, parse_time, parse_time_or_zero,
                            typed as _typed, whole_number as _count, to_celsius, to_kelvin)

if TYPE_CHECKING:
    from radiosim.camera import Camera

__all__ = ["main", "parse_time", "parse_length", "parse_temperature", "EXIT_INPUT",
           "EXIT_FAILURE", "EXIT_INTERRUPTED"]

#: Exit codes: a mistake in the input or the options, a failure while running, an interrupt.
EXIT_INPUT, EXIT_FAILURE, EXIT_INTERRUPTED = 2, 1, 130

#: The most Monte Carlo draws a budget may ask for (radiosim.uncertainty.MAX_DRAWS, kept equal
#: by a test; not imported here so that --help loads nothing heavy): GUM Supplement 1 (7.2.2)
#: finds 10⁶ enough for a 95 % coverage interval to two significant digits.
MAX_DRAWS = 1_000_000


def _run(args) -> int:
    """``radiosim run``."""
    _check_scheduler(args.scheduler)
    from radiosim.files import OutputFolder

    study = _study(args.study)
    draw = None if args.no_figures else study.hook("figures")
    study.scene  # build (and check) the scene before anything is written
    out = OutputFolder(Path(args.out or f"radiosim-{study.name}"), overwrite=args.overwrite,
                       inputs=study.inputs())
    completed = False
    try:
        # What is loaded (modules, the study, its scene) lives to the end: the garbage
        # collections the run's many small objects set off need not walk it every time.
        gc.freeze()
        print(f"radiosim {__version__}: study {study.name} → {out.path}/")
        if study.description:
            print(f"  {study.description}")
        progress = _Progress("measurement", args.quiet)
        _compiling().announce_compile(args, chip=True)
        result = study.run(out.staging, rng=args.seed, write_exr=not args.no_exr,
                           progress=None if args.quiet else progress,
                           scheduler=args.scheduler, workers=args.workers,
                           cluster=args.cluster, figures=draw is not None)
        progress.close()
        if draw is not None and not args.quiet:
            print("drawing the figures", file=sys.stderr, flush=True)
        figures = [] if draw is None else draw(out.staging, study.scene)
        from radiosim.io.writers import RESULTS_FORMATS  # e.g. netcdf: results.nc too

        RESULTS_FORMATS[args.format].write(out.staging, result,
                                           history=getattr(args, "command_line", None))
        written = out.commit()
        completed = True
    finally:
        gc.unfreeze()
        if not completed:
            kept = out.abandon(keep=True)
            if kept is not None:
                print(f"radiosim: the run did not complete; its finished measurements are in "
                      f"{kept}/", file=sys.stderr)
    from radiosim.study import format_table

    summary = study.hook("summary")
    print("\n".join(format_table(result.rows, getattr(summary, "table_columns", ()))))
    exr = sum(1 for r in result.rows if r.get("exr"))
    print(f"wrote {out.path / 'results.csv'}, {len(result.rows)} rows"
          + (f"; {exr} EXR files in {out.path / 'exr'}" if exr else ""))
    for path in figures:
        print(f"wrote {out.path / path.relative_to(out.staging)}")
    logging.getLogger(__name__).info("%d files in %s", len(written), out.path)
    return 0


def _measure(args) -> int:
    from radiosim.acquisition import frame_dtype
    from radiosim.io import SceneArgumentError, read_scene
    from radiosim.io.writers import write_measurement
    from radiosim.reporting import bad_sample_in, is_bad_sample, measurement_lines
    from radiosim.study import summarise

    camera = _camera(args.camera, args.pixel_pitch)
    path = Path(args.scene)
    try:  # the file by its suffix (radiosim.io.SCENE_TYPES); refusals in the options' words
        scene = read_scene(path, dt=args.dt, dx=args.dx, units=args.units,
                           time_unit=args.time_unit, length_unit=args.length_unit,
                           fill=args.fill)
    except SceneArgumentError as exc:
        raise RadiosimError(_scene_refusal(exc, args)) from None
    from radiosim.io.writers import MEASUREMENT_WRITERS

    _check_out_file(args, tuple(MEASUREMENT_WRITERS), "radiosim measure writes one file of "
                    + " or ".join(w.description for w in MEASUREMENT_WRITERS.values()))
    if args.out:
        from radiosim.files import check_not_an_input

        check_not_an_input(args.out, [*getattr(scene, "paths", ()), path])
    _check_scale(args, scene, camera)
    # A long measurement: per block of frames, on a terminal only (in a log, an error after
    # the work stays the one line on stderr).
    progress = _Progress("frame", args.quiet, delay=2.0, terminal_only=True)
    _compiling().announce_compile(args, frame_dtype(scene))
    try:
        # $RADIOSIM_SCHEDULER for a camera whose measurement can be split (one band); a
        # --scheduler given for one of several channels is refused in one line
        scheduler = args.scheduler if args.scheduler is not None else (
            os.environ.get("RADIOSIM_SCHEDULER") or None if camera.channels is None else None)
        m = camera.measure(scene, args.integration_time, args.start, args.seed,
                           scheduler=scheduler,
                           progress=lambda done, total: progress(done, total, "frames"))
    except RadiosimError as exc:  # the library states SI values: add the user's own
        if "--integration-time" in str(exc) or "Dask" in str(exc):  # not the window's
            raise
        if is_bad_sample(str(exc)):  # the file's fault, not the window's
            raise type(exc)(f"{path}: {bad_sample_in(str(exc), args.units)}") from None
        given = f"--integration-time {_typed(args.integration_time)}" + (
            f", --start {_typed(args.start)}" if args.start is not None else "")
        raise type(exc)(f"{exc} ({given})") from None
    summary = summarise(m)
    print("\n".join(measurement_lines(m, summary)))
    if summary["under_range_fraction"] == 1.0:
        _explain_under_range(args, camera, summary["peak_scene_C"], m)
    if args.out:
        print(f"wrote {write_measurement(args.out, m, history=args.command_line)}")
    return 0


def _explain_under_range(args, camera: Camera, peak_scene_C: float, measurement):
    """Say why a measurement read nothing: the scene is below what the camera can tell from its
    dark level at this integration time (and, for a scene read as kelvin that would be a
    plausible one in °C, ask whether the file was in °C)."""
    from radiosim.reporting import under_range_lines

    print("\n".join(under_range_lines(camera, args.integration_time, peak_scene_C,
                                      measurement)))
    peak_K = float(to_kelvin(peak_scene_C, "C"))
    if args.units == "K" and peak_scene_C < 0.0 < peak_K:
        print(f"  were the frames in °C? They were read as kelvin (--units K): a peak of "
              f"{peak_K:g} K; give --units C if it is {peak_K:g} °C")


def _add_dask_options(parser, what: str):
    """The ``--scheduler`` and ``--workers`` options of a command that can run on Dask."""
    parser.add_argument("--scheduler", default=os.environ.get("RADIOSIM_SCHEDULER") or None,
                        help=f"run {what} as Dask tasks: synchronous, threads or "
                        "tcp://HOST:PORT (default $RADIOSIM_SCHEDULER; none: in this process)")
    parser.add_argument("--workers", type=_count(1, what="a number of workers"), default=None,
                        help=f"run {what} on a local Dask cluster of N worker processes")


def _add_seed(parser, default=0, said="0"):
    parser.add_argument("--seed", type=_count(0, what="a seed (a whole number)"), default=default,
                        help=f"noise seed ≥ 0 (default {said})")


def _add_out_folder(parser, default: str, previous: str):
    """``--out FOLDER`` and ``--overwrite`` of a command that writes a folder."""
    parser.add_argument("--out", help=f"output folder, new or empty (default {default})")
    parser.add_argument("--overwrite", action="store_true",
                        help=f"replace the files of radiosim's previous {previous}")


def _add_quiet(parser):
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress bar nor compile notice")


def _add_out_file(parser, what: str):
    """The ``--out FILE`` and ``--overwrite`` options of a command that writes one file."""
    parser.add_argument("--out", help=f"write {what} to this file (a new one)")
    parser.add_argument("--overwrite", action="store_true", help="replace --out if it exists")


def _sse(args) -> int:
    import numpy as np

    from radiosim.characterization import fit_curve_halo, size_of_source, sse_diameters
    from radiosim.files import write_text
    from radiosim.reporting import sse_csv, sse_lines

    camera = _camera(args.camera, command="sse")
    _check_frame_period(camera, args, default=10e-6)
    _check_out_file(args, ".csv", "the SSE curve is a CSV table")
    pitch = camera.fpa.pixel_pitch
    diameters = np.array(args.diameters) if args.diameters else sse_diameters(pitch)
    progress = _Progress("disc", args.quiet)
    _compiling().announce_compile(args)
    curve = size_of_source(camera, diameters, args.temperature, args.background,
                           args.integration_time, progress=progress)
    psf = ", ".join(type(p).__name__ for p in camera.optics.psf or ()) or "perfect lens"
    print(f"{camera.name} ({psf}): size-of-source effect, a {to_celsius(args.temperature):g} °C "
          f"disc on {to_celsius(args.background):g} °C, {args.integration_time * 1e6:g} µs")
    print("\n".join(sse_lines(curve, fit_curve_halo(curve, pitch))))
    if args.out:
        write_text(args.out, sse_csv(curve))
        print(f"wrote {args.out}")
    return 0


def _study(target: str):
    from radiosim.study import Study, available_studies

    if Path(target).suffix == ".toml" or Path(target).is_file():
        return _from_file(target, "study file", Study.from_toml)
    if target in available_studies():
        return Study.preset(target)
    raise RadiosimError(f"{target!r} is neither a study file nor a shipped study "
                        f"({', '.join(available_studies())})")


def _uncertainty(args) -> int:
    from radiosim.files import OutputFolder
    from radiosim.reporting import budget_lines, write_budget

    _check_scheduler(args.scheduler)
    study = _study(args.study)
    spec = study.uncertainty
    if spec is None:
        raise RadiosimError(f"study {study.name} has no [uncertainty] table (see docs/"
                            "user_guide.md)")
    study.scene  # build (and check) the scene before anything is written
    out = OutputFolder(Path(args.out or f"radiosim-{study.name}-uncertainty"),
                       overwrite=args.overwrite, inputs=study.inputs())
    draws = args.draws if args.draws is not None else spec.draws
    print(f"radiosim {__version__}: uncertainty of study {study.name} → {out.path}/ "
          f"({draws or 'adaptive'} draws, {', '.join(spec.inputs)} and the noise)")
    bar = _Progress("draw", args.quiet)
    _compiling().announce_compile(args, chip=True)

    def progress(done, total, seconds_left=None):
        bar(done, total, "draws" + ("" if seconds_left is None
                                    else f", about {seconds_left:.0f} s left"))

    completed = False
    try:
        result = study.propagate(draws=args.draws, seed=args.seed, scheduler=args.scheduler,
                                 workers=args.workers, progress=None if args.quiet else progress)
        bar.close()
        write_budget(out.staging, result, study.name, study.cameras[spec.camera],
                     spec.integration_time)
        out.commit()
        completed = True
    finally:
        if not completed:
            out.abandon(keep=False)
    print("\n".join(budget_lines(result)))
    print(f"wrote {out.path / 'budget.csv'}, uncertainty.exr, budget.png")
    return 0


def _calibrate(args) -> int:
    from radiosim.calibration_table import (calibrate_from_table, check_tables_per_channel,
                                            fitted_camera_toml)
    from radiosim.files import write_text
    from radiosim.reporting import calibration_lines

    camera = _camera(args.camera, command="calibrate")
    _check_frame_period(camera, args)
    from radiosim.files import why_not_a_file

    paths = check_tables_per_channel(camera, [Path(table) for table in args.table])
    for path in paths:
        why = why_not_a_file(path)
        if why is not None:
            raise RadiosimError(f"{path} {why} (expected a CSV of temperature_K or "
                                "temperature_C, and counts)")
    _check_out_file(args, ".toml", "the fitted camera is a TOML file")
    progress = _Progress("step", args.quiet)
    _compiling().announce_compile(args)
    # The library reads and checks each table (columns, units, BOM, monotonic counts) and
    # checks each point against the full well and the converter's range.
    try:
        fitted, residuals, tables = calibrate_from_table(
            camera, paths if camera.channels is not None else paths[0],
            args.integration_time, frames=args.frames,
            exclude_unusable=args.exclude_unusable, fit_full_well=args.fit_full_well,
            progress=progress)
    finally:
        progress.close()
    if camera.channels is None:
        print("\n".join(calibration_lines(camera, fitted, tables, residuals, paths[0].name,
                                          args.integration_time)))
    else:
        for own, fit, table, residual, path in zip(camera.channel_cameras,
                                                  fitted.channel_cameras, tables, residuals,
                                                  paths):
            print("\n".join(calibration_lines(own, fit, table, residual, path.name,
                                              args.integration_time)))
    if args.out:  # over the camera file's text (its comments kept), with the fit's record
        write_text(args.out, fitted_camera_toml(camera, fitted, args.camera, paths,
                                                args.integration_time))
        print(f"wrote {args.out}")
    return 0


def _report(args) -> int:
    from radiosim.characterization import datasheet, datasheet_plan
    from radiosim.files import OutputFolder
    from radiosim.reporting import DATASHEET_FIGURES, datasheet_lines, write_datasheet

    camera = _camera(args.camera, command="report")
    _check_frame_period(camera, args, default=240e-6)
    t_int = args.integration_time
    plan = datasheet_plan(camera, t_int)  # the levels, checked against the camera
    if args.frames < 2:
        raise RadiosimError(f"--frames must be ≥ 2 (temporal variances need two read-outs), "
                            f"got {args.frames}")
    out = OutputFolder(Path(args.out or f"radiosim-report-{camera.name}"),
                       overwrite=args.overwrite)
    print(f"radiosim {__version__}: datasheet of {camera.name} at {t_int * 1e6:g} µs → "
          f"{out.path}/")
    progress = _Progress("step", args.quiet)
    _compiling().announce_compile(args)
    completed = False
    try:
        sheet = datasheet(camera, t_int, plan.ptc_temperatures, plan.netd_temperatures,
                          plan.range_times, frames=args.frames, rng=args.seed,
                          progress=progress)
        write_datasheet(out.staging, sheet, camera, t_int)
        out.commit()
        completed = True
    finally:
        if not completed:
            out.abandon(keep=False)
    print("\n".join(datasheet_lines(sheet)))
    print(f"wrote {out.path / 'datasheet.csv'} ({len(sheet.rows)} rows), "
          + ", ".join(f"{name}.png" for name in DATASHEET_FIGURES))
    return 0


def _compiling():
    """:mod:`radiosim.warmup`, the command's side of compiling (loaded when a command needs
    it: ``--help`` stays light)."""
    from radiosim import warmup

    return warmup


def _presets(args) -> int:
    from radiosim.reporting import catalogue_lines

    print("\n".join(catalogue_lines()))
    return 0


def _example_data(args) -> int:
    from radiosim.example_data import write_example_data

    files = write_example_data(args.folder)
    print(f"wrote {len(files)} example files in {args.folder} (what each is: "
          "python -m pydoc radiosim.example_data)")
    return 0


def _preview(args) -> int:
    from radiosim.paper import preview_scene
    from radiosim.scenes import SegmentedChip

    _check_out_file(args, ".png", "the preview is a PNG")
    scene = SegmentedChip(args.params) if args.params else SegmentedChip()
    t = args.time if args.time is not None else scene.event_time
    preview_scene(scene, t, args.out)
    print(f"wrote {args.out} (t = {t * 1e6:.2f} µs)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="radiosim", description="Radiometric simulation of infrared cameras.",
        epilog="Exit codes: 0 done, 2 a mistake in the input or options, 1 a failure while "
        "running, 130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"radiosim {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress")
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an error instead of one line")
    sub = parser.add_subparsers(dest="command", required=True)
    sub._parser_class = _Parser
    run = sub.add_parser("run", help="run a study (default: the paper's, msec2009)",
                         description="Run a study: every measurement of its sweeps, then "
                         "results.csv, EXR files and the paper's figures in --out.")
    run.add_argument("study", nargs="?", default="msec2009",
                     help="a study TOML file or a shipped study name (default msec2009)")
    _add_out_folder(run, "radiosim-STUDY", "run in --out (only those its manifest lists; "
                    "other files are never touched)")
    _add_seed(run)
    run.add_argument("--no-exr", action="store_true",
                     help="write no EXR files (then no maps nor profiles either)")
    run.add_argument("--no-figures", action="store_true", help="write no figures")
    from radiosim.io.writers import RESULTS_FORMATS

    run.add_argument("--format", choices=list(RESULTS_FORMATS), default="exr",
                     help="; ".join(f"{f.name}: {f.description}"
                                    for f in RESULTS_FORMATS.values()) + " (default exr)")
    _add_quiet(run)
    _add_dask_options(run, "the measurements")
    run.add_argument("--cluster", choices=["auto", "always"], default="auto",
                     help="with --workers: auto starts the cluster only where the estimate "
                     "says it pays (else it says why and measures in this process); always "
                     "starts it regardless")
    run.set_defaults(func=_run)
    measure = sub.add_parser("measure", help="measure one scene file with one camera",
                             description="Measure a scene file (.npy, .npz, a folder or glob "
                             "of .exr frames, or an FEA nodal .csv) with one camera.")
    measure.add_argument("scene", help="scene file, EXR folder or pattern")
    measure.add_argument("--camera", default="nist-ir",
                         help="preset name, linear-ideal, or a camera TOML (default nist-ir)")
    measure.add_argument("--integration-time", type=parse_time, required=True, metavar="T",
                         help="integration time with a unit, e.g. 10us")
    measure.add_argument("--start", type=parse_time_or_zero, default=None,
                         help="window start, e.g. 45us (default: from 0 or centred on the "
                         "scene's event)")
    measure.add_argument("--dt", type=parse_time, help="frame interval, e.g. 0.2us")
    measure.add_argument("--dx", type=parse_length, help="sample pitch, e.g. 0.5um")
    measure.add_argument("--pixel-pitch", type=parse_length,
                         help="object-space pixel pitch, e.g. 6um (linear-ideal needs it)")
    measure.add_argument("--units", choices=["K", "C"], help="temperature unit of the file")
    measure.add_argument("--scheduler", default=None,
                         help="integrate the window's parts (64 frames or more each) as Dask tasks: "
                         "synchronous, threads or tcp://HOST:PORT (default "
                         "$RADIOSIM_SCHEDULER; none: in this process); the same bits")
    measure.add_argument("--time-unit", choices=["s", "ms", "us", "ns"],
                         help="FEA CSV time unit")
    measure.add_argument("--length-unit", choices=["m", "mm", "um"], help="FEA CSV length unit")
    measure.add_argument("--fill", type=parse_temperature, default=None,
                         help="FEA: temperature outside the mesh, e.g. 20C (default 20C)")
    _add_seed(measure)
    _add_out_file(measure, "the measurement (.exr)")
    _add_quiet(measure)
    measure.set_defaults(func=_measure)
    unc = sub.add_parser("uncertainty", help="the Monte Carlo uncertainty budget of a study",
                         description="Propagate a study's [uncertainty] inputs through its "
                         "camera (GUM Supplement 1 Monte Carlo on Dask) and write budget.csv, "
                         "uncertainty.exr and budget.png in --out.")
    unc.add_argument("study", help="a study TOML file with an [uncertainty] table")
    unc.add_argument("--draws", type=_count(1, MAX_DRAWS, "a number of draws"), default=None,
                     help="Monte Carlo draws, 1 to 1,000,000 (default: the study's, else "
                     "adaptive)")
    _add_seed(unc, None, "the study's")
    _add_dask_options(unc, "the draws")
    _add_out_folder(unc, "radiosim-STUDY-uncertainty", "run in --out")
    _add_quiet(unc)
    unc.set_defaults(func=_uncertainty)
    sse = sub.add_parser("sse", help="the size-of-source curve of a camera",
                         description="Image uniform blackbody discs of increasing diameter "
                         "through the camera's optics (MSL Technical Guide 26) and print the "
                         "size-of-source effect; a scatter halo is fitted to the large discs.")
    sse.add_argument("camera", help="preset name or camera TOML")
    sse.add_argument("--temperature", type=parse_temperature, default=1273.15,
                     help="disc temperature, e.g. 1000C (default 1000C)")
    sse.add_argument("--background", type=parse_temperature, default=AMBIENT_TEMPERATURE,
                     help="background temperature, e.g. 20C (default 20C)")
    sse.add_argument("--diameters", type=parse_length, nargs="+",
                     help="disc diameters, e.g. 12um 60um 600um (default 2 to 200 pixels)")
    sse.add_argument("--integration-time", type=parse_time, metavar="T",
                     help="integration time (default 10us)")
    _add_out_file(sse, "the curve (.csv)")
    _add_quiet(sse)
    sse.set_defaults(func=_sse)
    cal = sub.add_parser("calibrate", help="fit a camera's gain and offset to a measured "
                         "calibration table",
                         description="Fit the camera's system gain and offset to a CSV of "
                         "blackbody temperatures (temperature_K or temperature_C) and mean "
                         "counts, through radiosim's radiometry with the camera's curves; with "
                         "an instrument_temperature_K (or _C) column, the optics' emissivity "
                         "too.")
    cal.add_argument("table", nargs="+", help="CSV with temperature_K (or temperature_C) and "
                     "counts; a camera of several channels takes one per channel, in order")
    cal.add_argument("--camera", required=True, help="preset name or camera TOML")
    cal.add_argument("--integration-time", type=parse_time, required=True, metavar="T",
                     help="integration time of the table, e.g. 100us")
    cal.add_argument("--frames", type=_count(1, what="a number of read-outs"), default=1,
                     help="read-outs averaged in each counts value (default 1)")
    cal.add_argument("--exclude-unusable", action="store_true",
                     help="leave out (with a warning naming them) the points past the full well "
                     "or the converter's range, instead of refusing the table")
    cal.add_argument("--fit-full-well", action="store_true",
                     help="raise the full well to hold the points past it")
    _add_out_file(cal, "the fitted camera (.toml)")
    _add_quiet(cal)
    cal.set_defaults(func=_calibrate)
    report = sub.add_parser("report", help="an EMVA 1288-style datasheet of a camera",
                            description="Characterise a camera as an EMVA 1288 report does: "
                            "gain, dark noise, saturation capacity, DSNU, PRNU, linearity "
                            "error, NETD curve and measurable range; datasheet.csv and figures "
                            "in --out.")
    report.add_argument("camera", help="preset name or camera TOML")
    report.add_argument("--integration-time", type=parse_time, metavar="T",
                        help="integration time of the datasheet (default 240us)")
    report.add_argument("--frames", type=_count(2, what="a number of read-outs (temporal "
                        "variances need two)"), default=16,
                        help="read-outs per flat field (default 16)")
    _add_seed(report)
    _add_out_folder(report, "radiosim-report-CAMERA", "report in --out")
    _add_quiet(report)
    report.set_defaults(func=_report)
    warm = sub.add_parser("warmup", help="compile radiosim's kernels ahead of time (once)",
                          description="Compile every kernel "
                          "path (float32 and float64 frames, memory maps, linear and Planck "
                          "responses, emissivity maps, the chip's moving terms) into numba's "
                          "on-disk cache, so that no later run waits for a compilation.")
    _add_quiet(warm)
    warm.set_defaults(func=lambda args: _compiling().warmup_command(args))
    presets = sub.add_parser("presets", help="list the cameras and studies")
    presets.set_defaults(func=_presets)
    example = sub.add_parser("example-data", help="write the files the README's and guides' "
                             "examples read (frames, EXR, FEA nodes and mesh, a calibration "
                             "table) into a new or empty folder")
    example.add_argument("folder", help="a new or empty folder (. for the current one)")
    example.set_defaults(func=_example_data)
    from radiosim.cli_recording import (add_compare_parser, add_correct_parser,
                                        add_recording_parser)

    add_recording_parser(sub)
    add_compare_parser(sub)
    add_correct_parser(sub)
    scene = sub.add_parser("scene", help="the built-in segmented-chip scene")
    scene_sub = scene.add_subparsers(dest="scene_command", required=True, metavar="preview")
    preview = scene_sub.add_parser("preview", help="write a PNG of the scene with the tool, "
                                   "shear plane and Columns I-III (like the paper's Figure 4)")
    preview.add_argument("--time", type=parse_time, default=None,
                         help="time with a unit (default: the fully developed band)")
    preview.add_argument("--params", help="TOML file of chip parameters")
    preview.add_argument("--out", default="scene.png", help="PNG path (default scene.png)")
    preview.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    preview.set_defaults(func=_preview)
    return parser


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors and the documented exit code."""

    def error(self, message):
        message = _unexpanded(message)  # files the shell expanded from a pattern: said so
        self.exit(EXIT_INPUT, f"radiosim: error: {message} (see {self.prog} --help)\n")


def main(argv=None) -> int:
    """Run the command; returns the exit code (see the module docstring). As the ``radiosim``
    command itself (no ``argv``), it ends the process when the command is done
    (:func:`radiosim.cli_signals.exit_done`)."""
    code = _command(argv)
    if argv is None:
        _exit_done(code)
    return code


def _command(argv) -> int:
    """:func:`main`'s work."""
    command = argv is None  # the radiosim command itself (tests pass their argv)
    parser = build_parser()
    words = sys.argv[1:] if argv is None else [str(a) for a in argv]
    args = parser.parse_args(_join_negatives(parser, words))
    args.command_line = shlex.join(["radiosim", *words])  # a results file's history
    if command:
        _outlive_the_reader()  # `radiosim run | head -1` runs to the end, quietly
        _encode_what_it_can()  # PYTHONIOENCODING=ascii: µ and ° escaped, not a crash
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    # The work's handlers: Ctrl-C and SIGTERM unwind (every ``finally`` removes its temporary
    # files), then one line. They replace the start-up handlers (radiosim.cli_signals), which end
    # the process at once, and are restored after.
    signals = (signal.SIGINT, signal.SIGTERM)
    in_main_thread = _main_thread()
    previous = {s: signal.getsignal(s) for s in signals} if in_main_thread else {}
    if command:
        # After an interrupt the command ends its local cluster's workers at once (see
        # _exit_now), and multiprocessing's resource tracker (a process of its own, started
        # with these options) unlinks what they left: it need not tell the user it did.
        sys.warnoptions.append("ignore::UserWarning:multiprocessing.resource_tracker")
    if in_main_thread:
        if previous[signal.SIGINT] is not signal.SIG_IGN:  # e.g. a background job
            signal.signal(signal.SIGINT, _interrupt)
        signal.signal(signal.SIGTERM, _interrupt)
    unraisable = sys.unraisablehook
    if command:  # an interrupt raised in a callback from C: sent again, not reported
        sys.unraisablehook = _on_unraisable
    _Command.active, _Command.interrupted = command, False
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            warnings.simplefilter("default", RadiosimWarning)
            return args.func(args)
    except (KeyboardInterrupt, Interrupted) as exc:
        if args.debug:
            raise
        return _end_interrupted(command, "SIGTERM" if isinstance(exc, Interrupted) else "Ctrl-C")
    except RadiosimError as exc:
        if args.debug:
            raise
        if _Command.interrupted:  # the interrupt surfaced as another error: still an interrupt
            return _end_interrupted(command, _Command.signal_name)
        print(f"radiosim: error: {exc}", file=sys.stderr)
        return EXIT_FAILURE if isinstance(exc, RadiosimIOError) else EXIT_INPUT
    except OSError as exc:
        if args.debug:
            raise
        if _Command.interrupted:
            return _end_interrupted(command, _Command.signal_name)
        if _short_of_memory(exc):
            return EXIT_FAILURE
        where = f" {exc.filename}" if exc.filename else ""
        print(f"radiosim: error:{where} {exc.strerror or exc}", file=sys.stderr)
        return EXIT_FAILURE
    except Exception as exc:  # a bug, not a user mistake: say so, in one line
        if args.debug:
            raise
        if _Command.interrupted:  # e.g. an import the signal cut short ("initialization failed")
            return _end_interrupted(command, _Command.signal_name)
        if _short_of_memory(exc) or _damaged_cache(exc):
            return EXIT_FAILURE
        if _bad_mplbackend(exc):
            return EXIT_INPUT
        print(f"radiosim: internal error ({type(exc).__name__}: {exc}); run with --debug for "
              "the traceback and please report it", file=sys.stderr)
        return EXIT_FAILURE
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        sys.unraisablehook = unraisable
        if _Command.interrupted:  # only the command silences logging (and then exits)
            logging.disable(logging.NOTSET)
        _Command.active = False


def _end_interrupted(command: bool, what: str) -> int:
    """One line for an interrupted command (its cleanup done), exit 130."""
    if command:  # the cleanup is done: a second signal must not cut the one line
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, signal.SIG_IGN)
    print(f"radiosim: interrupted ({what}); temporary files removed", file=sys.stderr)
    if command:
        _exit_now()
    return EXIT_INTERRUPTED


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


if __name__ == "__main__":
    sys.exit(main())

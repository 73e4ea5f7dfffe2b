"""
Benchmark: radiosim in a new user's hands (issue 22), from one run, as a table of seconds and
ratios next to the issue's targets.

- start-up, each the best of ``--repeat`` fresh processes: ``python -c "import numpy"`` (the
  reference), ``radiosim --help``, ``radiosim --version``, an argument error (``radiosim
  measure`` without its scene file: exit 2) and ``python -c "import radiosim"``;
- compile: ``radiosim run --out TMP -q`` (the paper's study, EXR files and figures) with
  ``NUMBA_CACHE_DIR`` set to a new, empty folder, minus the same run warm: every kernel the
  default study uses, compiled (the integrator's, which serves every frame dtype, and the
  chip's; the sub-band kernel of a PSF, which the study does not take, is not in it);
- the warm run: the same command again, end to end, and its parts timed inside one process as
  the CLI runs them: import of ``radiosim.cli`` and the study's load (scene built), the
  measurements (``study.run``) and the ``figures`` hook;
- the other timed commands (``sse``, ``report``, ``uncertainty`` on their presets),
  once each after ``radiosim warmup`` (left out with ``--no-commands``).

Everything is written in a temporary folder, removed at the end; numba's cache for the runs is
in it too (the user's cache is neither read nor written; matplotlib's font cache is read
where it is, as every run reads it). Python's bytecode is read and written where Python keeps
it (``PYTHONDONTWRITEBYTECODE`` unset), as a user's runs do: the installed libraries' bytecode
is the one ``pip install`` wrote, and radiosim's is written by the first process if missing,
as at a user's first import. (An earlier version put the bytecode in a new folder under the
temporary one, ``PYTHONPYCACHEPREFIX``: then the cold run, the first process to import numba,
scipy and matplotlib, also compiled their Python sources, 5-6 s on 2 cores that no
installed copy pays, and counted them as kernel compile.) The machine's load shows in the
numbers: run it on a quiet host for the documented times. Run on demand:

    python benchmarks/bench_cli.py [--repeat 5] [--no-commands] [--write-docs [PAGE]]

``--write-docs`` also writes the run's table, its date and the host's speed probe into
docs/performance.md (or PAGE), replacing what stands between its ``<!-- bench_cli: begin -->``
and ``<!-- bench_cli: end -->`` lines (the page is checked for them before the run).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import textwrap
import time
from importlib import metadata
from pathlib import Path

from _host import speed_probe

# Run in a fresh process: the warm run's parts, timed as radiosim.cli._run does them.
_PARTS = """
import json, pathlib, sys, time
pathlib.Path(sys.argv[1]).mkdir()
t0 = time.perf_counter()
import radiosim.cli as cli
study = cli._study("msec2009")
draw = study.hook("figures")
study.scene
t1 = time.perf_counter()
study.run(sys.argv[1], write_exr=True, progress=None)
t2 = time.perf_counter()
draw(sys.argv[1], study.scene)
t3 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "measurements": t2 - t1, "figures": t3 - t2}))
"""


#: The other commands with a time in docs/performance.md, each timed once, warm (after
#: ``radiosim warmup`` in the benchmark's numba cache), into a new folder.
README_COMMANDS = ((["sse", "nist-ir-psf"], "sse.csv"), (["report", "nist-ir-fpa"], "sheet"),
                   (["uncertainty", "chip-budget"], "budget"))

#: The page ``--write-docs`` writes into, and the lines its table goes between.
DOCS_PAGE = Path(__file__).resolve().parent.parent / "docs" / "performance.md"
BEGIN, END = "<!-- bench_cli: begin -->", "<!-- bench_cli: end -->"


def _marked_block(text: str, page) -> tuple[int, int]:
    """Offsets of the text between the lines ``BEGIN`` and ``END`` of ``text`` (the markers
    themselves excluded); SystemExit naming ``page`` unless each appears once, in that order, on
    a line of its own."""
    lines = text.splitlines(keepends=True)
    found = {BEGIN: [], END: []}
    offset = 0
    for line in lines:
        if line.strip() in found:
            found[line.strip()].append((offset, offset + len(line)))
        offset += len(line)
    for marker, where in found.items():
        if len(where) != 1:
            raise SystemExit(f"{page}: {'no' if not where else len(where)} line"
                             f"{'s' * (len(where) > 1)} {marker!r}; expected exactly one")
    (_, start), (end, _) = found[BEGIN][0], found[END][0]
    if end < start:
        raise SystemExit(f"{page}: {END!r} comes before {BEGIN!r}")
    return start, end


def _source() -> str:
    """radiosim's version and, where this is a git checkout, its commit (and whether radiosim's
    sources differ from it)."""
    try:
        text = f"radiosim {metadata.version('radiosim')}"
    except metadata.PackageNotFoundError:
        text = "radiosim (not installed)"
    root = Path(__file__).resolve().parent.parent
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True, timeout=10)
        changed = subprocess.run(["git", "-C", str(root), "status", "--porcelain",
                                  "--untracked-files=no", "--", "radiosim"],
                                 capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return text
    if commit.returncode == 0 and commit.stdout.strip():
        text += f" at commit {commit.stdout.strip()}"
        if changed.returncode == 0 and changed.stdout.strip():
            text += " with local changes to radiosim/"
    return text


#: The commands and names in a row's text, set as code on the page (so that ``--help`` stays
#: two hyphens and the quotes straight).
_CODE = re.compile(r"python -c '[^']*'|radiosim\.\w+|radiosim(?: [a-z][a-z-]*| --[a-z]+)*"
                   r"|study\.run")


def docs_block(rows, when, probes, load, repeat, commands=True, source=None) -> str:
    """The Markdown ``--write-docs`` puts between the markers: the run's date [UTC], the host
    (cores, load average, speed probe before and after [s]), what was measured and the table
    of ``rows`` (what, seconds, ratio to numpy's import or None, target text, met or None)."""
    source = _source() if source is None else source
    before, after = probes
    heading = (
        f"Written by `python benchmarks/bench_cli.py --write-docs` on "
        f"{when.astimezone(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC: {source}, Python "
        f"{platform.python_version()}, {os.cpu_count()} cores, load average "
        f"{', '.join(f'{x:.1f}' for x in load)}; host speed probe, `sum(range(10**7))`: "
        f"{before:.3f} s before, {after:.3f} s after (about 0.17 s on a quiet host). Start-up "
        f"times are the best of {repeat} fresh processes; every other time is one run"
        + ("" if commands else " (the laboratory commands left out: `--no-commands`)") + ".")
    lines = [
        textwrap.fill(heading, 100, break_long_words=False, break_on_hyphens=False),
        "",
        "| what | seconds | × numpy | target | met |",
        "| --- | ---: | ---: | --- | --- |",
    ]
    for what, seconds, ratio, target, met in rows:
        code = _CODE.sub(lambda match: f"`{match[0]}`", what.strip())
        what = f"– {code}" if what.startswith(" ") else code
        ratio = "" if ratio is None else f"{ratio:.1f}"
        met = "" if met is None else ("yes" if met else "no")
        target = target.replace("<=", "≤").replace("x numpy", "× numpy")
        lines.append(f"| {what} | {seconds:.2f} | {ratio} | {target} | {met} |")
    return "\n".join(lines) + "\n"


def write_docs(page, block: str) -> None:
    """Replace the text between ``page``'s marker lines with ``block``, the rest of the page as
    it was; written under a temporary name beside it and renamed into place."""
    page = Path(page)
    text = page.read_text(encoding="utf-8")
    start, end = _marked_block(text, page)
    partial = page.with_name(f".{page.name}.bench_cli.tmp")
    partial.write_text(text[:start] + block + text[end:], encoding="utf-8")
    os.replace(partial, page)


def _cpu():
    """CPU time [s], user and system, of this process's finished children."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _seconds(command, env, check=True, expect=0, cpu=None):
    """Wall time [s] of ``command`` in a fresh process; its exit status must be ``expect``.
    Its CPU time [s] is appended to the list ``cpu`` if given."""
    t0, c0 = time.perf_counter(), _cpu()
    done = subprocess.run(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True)
    elapsed = time.perf_counter() - t0
    if cpu is not None:
        cpu.append(_cpu() - c0)
    if check and done.returncode != expect:
        raise SystemExit(f"{' '.join(map(str, command))} exited {done.returncode}, expected "
                         f"{expect}:\n{done.stderr[-2000:]}")
    return elapsed, done


def _best(command, env, repeat, expect=0):
    return min(_seconds(command, env, expect=expect)[0] for _ in range(repeat))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5,
                        help="fresh processes per start-up measurement; the best is kept")
    parser.add_argument("--no-commands", action="store_true",
                        help="leave out the laboratory commands: sse, report, uncertainty "
                        "(about 70 s)")
    parser.add_argument("--write-docs", nargs="?", const=DOCS_PAGE, default=None,
                        metavar="PAGE", help="also write the table into docs/performance.md "
                        f"(or PAGE), between its lines {BEGIN} and {END}")
    args = parser.parse_args(argv)
    if args.write_docs is not None:  # before minutes of work, not after
        try:
            _marked_block(Path(args.write_docs).read_text(encoding="utf-8"), args.write_docs)
        except OSError as error:
            raise SystemExit(f"--write-docs: cannot read {args.write_docs}: "
                             f"{error.strerror or error}") from None
    probe_before = speed_probe()

    python = sys.executable
    radiosim = [str(Path(python).with_name("radiosim"))]
    if not Path(radiosim[0]).is_file():
        radiosim = [python, "-c", "import sys; from radiosim.cli import main; sys.exit(main())"]
    tmp = Path(tempfile.mkdtemp(prefix="bench_cli_"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp / "numba-cache"))
    for name in ("PYTHONDONTWRITEBYTECODE", "PYTHONPYCACHEPREFIX"):
        env.pop(name, None)
    rows = []  # (what, seconds, ratio to numpy's import or None, target text, met)
    try:
        numpy = _best([python, "-c", "import numpy"], env, args.repeat)
        rows.append(("python -c 'import numpy' (reference)", numpy, 1.0, "", None))
        for what, command, expect in (
                ("radiosim --help", radiosim + ["--help"], 0),
                ("radiosim --version", radiosim + ["--version"], 0),
                ("argument error (radiosim measure, no file)", radiosim + ["measure"], 2)):
            t = _best(command, env, args.repeat, expect=expect)
            rows.append((what, t, t / numpy, "<= 3x numpy", t <= 3 * numpy))
        t = _best([python, "-c", "import radiosim"], env, args.repeat)
        rows.append(("python -c 'import radiosim'", t, t / numpy, "<= 6x numpy", t <= 6 * numpy))

        run = radiosim + ["run", "-q", "--overwrite", "--out"]
        cpu = []  # on a loaded host the CPU times tell the compile better than wall times
        cold, _ = _seconds(run + [str(tmp / "cold")], env, cpu=cpu)  # empty numba cache
        warm, _ = _seconds(run + [str(tmp / "warm")], env, cpu=cpu)
        compile_ = cold - warm
        rows.append(("radiosim run, empty numba cache", cold, None, "", None))
        rows.append(("  compile (cold run - warm run)", compile_, None, "<= 15 s",
                     compile_ <= 15))
        rows.append(("  compile, CPU time (cold - warm, user+sys)", cpu[0] - cpu[1], None,
                     "", None))
        rows.append(("radiosim run, warm, end to end", warm, None, "<= 8 s", warm <= 8))
        _, done = _seconds([python, "-c", _PARTS, str(tmp / "parts")], env)
        parts = json.loads(done.stdout.strip().splitlines()[-1])
        rows.append(("  import radiosim.cli + study load", parts["import"], None, "", None))
        rows.append(("  measurements (study.run)", parts["measurements"], None, "", None))
        rows.append(("  figures (the figures hook)", parts["figures"], None, "<= 1.5 s",
                     parts["figures"] <= 1.5))
        if not args.no_commands:
            t, _ = _seconds(radiosim + ["warmup", "-q"], env)
            rows.append(("radiosim warmup (after the runs)", t, None, "", None))
            for command, out in README_COMMANDS:
                t, _ = _seconds(radiosim + command + ["-q", "--out", str(tmp / out)], env)
                rows.append((f"radiosim {' '.join(command)}, warm", t, None, "", None))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    load, probe_after = os.getloadavg(), speed_probe()
    print(f"radiosim start-up and runs, {os.cpu_count()} cores, load average "
          f"{', '.join(f'{x:.1f}' for x in load)} (best of {args.repeat} for "
          "start-up; one run each otherwise)")
    print(f"host speed probe, sum(range(10**7)): {probe_before:.3f} s before, "
          f"{probe_after:.3f} s after (about 0.17 s on a quiet host)")
    print(f"| {'what':<45} | {'seconds':>7} | {'x numpy':>7} | {'target':<11} | met |")
    print(f"| {'-' * 45} | {'-' * 7} | {'-' * 7} | {'-' * 11} | --- |")
    for what, seconds, ratio, target, met in rows:
        ratio = "" if ratio is None else f"{ratio:.1f}"
        met = "" if met is None else ("yes" if met else "no")
        print(f"| {what:<45} | {seconds:>7.2f} | {ratio:>7} | {target:<11} | {met:<3} |")
    if args.write_docs is not None:
        block = docs_block(rows, datetime.datetime.now(datetime.timezone.utc),
                           (probe_before, probe_after), load, args.repeat,
                           commands=not args.no_commands)
        write_docs(args.write_docs, block)
        print(f"wrote the table into {args.write_docs}")


if __name__ == "__main__":
    main()

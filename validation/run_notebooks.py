"""
Execute the validation notebooks and save them with their outputs.

    python validation/run_notebooks.py              # full resolution, in place (a few minutes)
    python validation/run_notebooks.py --reduced    # the test suite's coarse settings, into --out

The notebooks read RADIOSIM_VALIDATION=reduced for the coarse settings. Each ends with a cell
tagged ``conclusion`` that writes the notebook's conclusion from its computed numbers (and
asserts its claims); the text it displays is copied into the notebook's first cell, so no
conclusion number is typed by hand.
"""

import argparse
import os
import sys
import time
from pathlib import Path

import re

import nbformat
from nbclient import NotebookClient

HERE = Path(__file__).resolve().parent
NOTEBOOKS = sorted(HERE.glob("[0-9][0-9]_*.ipynb"))


def conclusion_of(notebook) -> str | None:
    """The Markdown text displayed by the notebook's ``conclusion`` cell, if it ran."""
    for cell in notebook.cells:
        if "conclusion" in cell.get("metadata", {}).get("tags", []):
            for output in cell.get("outputs", []):
                text = output.get("data", {}).get("text/markdown")
                if text:
                    return "".join(text).strip()
    return None


def stated_conclusion(notebook) -> str:
    """The conclusion paragraph of the notebook's first cell."""
    match = re.search(r"\*\*Conclusion\.\*\*.*?(?=\n\n|\Z)", notebook.cells[0].source, re.S)
    return match.group(0).strip() if match else ""


def state_conclusion(notebook):
    """Replace the first cell's conclusion paragraph with the computed one."""
    computed = conclusion_of(notebook)
    if computed is None:
        raise RuntimeError("the notebook's conclusion cell displayed no Markdown")
    first = notebook.cells[0]
    first.source = first.source.replace(stated_conclusion(notebook), computed)


def execute(path: Path, reduced: bool, out: Path | None = None, timeout: int = 1800) -> Path:
    """Run one notebook top to bottom; write it (with outputs) to ``out`` or in place."""
    notebook = nbformat.read(path, as_version=4)
    # The kernel's environment: the settings, and with ``out`` its temporary folders (where
    # the notebooks write their results) inside ``out/tmp``, not left in the system's.
    environment = {"RADIOSIM_VALIDATION": "reduced" if reduced else "full"}
    if out is not None:
        scratch = Path(out) / "tmp"
        scratch.mkdir(parents=True, exist_ok=True)
        environment["TMPDIR"] = str(scratch)
    previous = {name: os.environ.get(name) for name in environment}
    os.environ.update(environment)
    try:
        NotebookClient(notebook, timeout=timeout, kernel_name="python3",
                       resources={"metadata": {"path": str(HERE)}}).execute()
    finally:
        for name, value in previous.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
    state_conclusion(notebook)
    target = (out / path.name) if out else path
    nbformat.write(notebook, target)
    return target


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--reduced", action="store_true", help="coarse settings (fast)")
    parser.add_argument("--out", type=Path, help="write executed notebooks here, not in place")
    parser.add_argument("notebooks", nargs="*", type=Path, help="default: all of them")
    args = parser.parse_args(argv)
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
    for path in args.notebooks or NOTEBOOKS:
        start = time.perf_counter()
        target = execute(Path(path).resolve(), args.reduced, args.out)
        print(f"{target}: {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

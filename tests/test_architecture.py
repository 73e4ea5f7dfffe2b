"""The package's imports flow one way, down the chain (radiosim.CHAIN)."""

import ast
from pathlib import Path

import radiosim

PACKAGE = Path(radiosim.__file__).resolve().parent


def _stage(module: str) -> str:
    """The chain entry of a dotted module name inside radiosim (its first component)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _imports(path: Path):
    """Every radiosim module a file imports, at any depth (late imports included)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("radiosim"):
                    yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith(
                "radiosim"):
            if node.module == "radiosim":  # from radiosim import x: x is a stage
                for alias in node.names:
                    yield f"radiosim.{alias.name}", node.lineno
            else:
                yield node.module, node.lineno


def test_every_module_is_in_the_chain():
    stages = {p.stem if p.is_file() else p.name for p in PACKAGE.iterdir()
              if (p.suffix == ".py" and p.stem != "__init__") or (p / "__init__.py").is_file()}
    stages.discard("__pycache__")
    assert stages == set(radiosim.CHAIN), stages ^ set(radiosim.CHAIN)


def test_no_module_imports_one_later_in_the_chain():
    order = {name: i for i, name in enumerate(radiosim.CHAIN)}
    offences = []
    for path in PACKAGE.rglob("*.py"):
        relative = path.relative_to(PACKAGE)
        own = relative.parts[0].removesuffix(".py")
        if own == "__init__":  # the package's front door imports everything
            continue
        for module, line in _imports(path):
            other = _stage(module)
            if other in ("__init__",) and module == "radiosim":
                continue
            if other == "__version__":
                continue
            if other not in order:
                offences.append(f"{relative}:{line} imports {module}, not in the chain")
            elif order[other] > order[own]:
                offences.append(f"{relative}:{line} ({own}) imports {module} ({other}), later "
                                "in the chain")
    assert not offences, "\n".join(offences)


def test_scenes_and_calibration_never_import_the_camera():
    for folder in ("scenes", "calibration.py", "response.py", "integrator.py"):
        for path in ([PACKAGE / folder] if folder.endswith(".py")
                     else (PACKAGE / folder).rglob("*.py")):
            assert not any(m.startswith("radiosim.camera") for m, _ in _imports(path)), path


def test_public_subpackages_are_attributes():
    import subprocess
    import sys

    code = ("import radiosim; print(radiosim.io.read_frames.__name__, "
            "radiosim.scenes.SegmentedChip.__name__, radiosim.paper.column_index.__name__, "
            "radiosim.study.Study.__name__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["read_frames", "SegmentedChip", "column_index", "Study"]

"""The packages' layering, enforced: the core (``sspinn``) imports none of the extensions, the
environment imports neither the agents nor the predictive package, and only the comparison
harness of ``predictive`` imports ``agents``. Every import statement counts, also those inside
functions (a hidden dependency is still a dependency)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sspinn", "envs", "predictive", "agents")

#: package → the project packages it may import
ALLOWED: dict[str, set[str]] = {
    "sspinn": {"sspinn"},
    "envs": {"sspinn", "envs"},
    "agents": {"sspinn", "envs", "agents"},
    "predictive": {"sspinn", "envs", "predictive"},
}

#: files allowed beyond their package's rule: the harness that compares the predictive controller
#: with the stable-baselines3 agents on the same environment needs both
EXCEPTIONS: dict[str, set[str]] = {"predictive/experiments/controller_comparison.py": {"agents"}}


def imported_packages(path: Path) -> dict[str, int]:
    """Project packages imported anywhere in ``path`` → the first line that imports each."""
    found: dict[str, int] = {}
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        for name in names:
            top = name.split(".")[0]
            if top in PACKAGES:
                found.setdefault(top, node.lineno)
    return found


def _files(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


@pytest.mark.parametrize("package", PACKAGES)
def test_package_imports_only_what_its_layer_allows(package: str) -> None:
    violations = []
    for path in _files(package):
        rel = path.relative_to(ROOT).as_posix()
        allowed = ALLOWED[package] | EXCEPTIONS.get(rel, set())
        violations += [f"{rel}:{line} imports {name}" for name, line in imported_packages(path).items() if name not in allowed]
    assert not violations, "layering broken:\n" + "\n".join(violations)


#: the rooms of ``sspinn`` → the rooms each may import. Plumbing (the top-level modules other than
#: ``cli``) imports only plumbing; the body model builds on plumbing; recordings on the model; real
#: IMU import and the estimator on recordings, never on each other; ``testing`` (test data) on all
#: of them; ``cli`` (and ``__init__``/``__main__``) on everything.
PLUMBING = "plumbing"
ROOM_ALLOWED: dict[str, set[str]] = {
    PLUMBING: {PLUMBING},
    "model": {PLUMBING, "model"},
    "data": {PLUMBING, "model", "data"},
    "imu": {PLUMBING, "model", "data", "imu"},
    "estimator": {PLUMBING, "model", "data", "estimator"},
    "testing": {PLUMBING, "model", "data", "imu", "estimator", "testing"},
    "top": {PLUMBING, "model", "data", "imu", "estimator", "testing", "top"},
}
TOP = {"__init__", "__main__", "cli"}


def room_of_module(dotted: str) -> str | None:
    """The room of an ``sspinn`` module (``sspinn.model.body`` → ``model``); ``None`` for the
    package itself (``from sspinn import x`` is resolved per name by the caller)."""
    parts = dotted.split(".")
    if parts[0] != "sspinn" or len(parts) == 1:
        return None
    if parts[1] in ROOM_ALLOWED and parts[1] != PLUMBING:
        return parts[1]
    return "top" if parts[1] in TOP else PLUMBING


def room_of_file(path: Path) -> str:
    rel = path.relative_to(ROOT / "sspinn")
    if len(rel.parts) > 1:
        return rel.parts[0]
    return "top" if rel.stem in TOP else PLUMBING


def imported_sspinn_modules(path: Path) -> list[tuple[str, int]]:
    """Every ``sspinn`` module imported in ``path`` (``from sspinn import a`` counts as ``sspinn.a``)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found += [(alias.name, node.lineno) for alias in node.names if alias.name.startswith("sspinn.")]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module == "sspinn":
                found += [(f"sspinn.{alias.name}", node.lineno) for alias in node.names]
            elif node.module.startswith("sspinn."):
                found.append((node.module, node.lineno))
    return found


def test_sspinn_rooms_import_only_what_their_layer_allows() -> None:
    violations = []
    for path in _files("sspinn"):
        room = room_of_file(path)
        for module, line in imported_sspinn_modules(path):
            target = room_of_module(module)
            if target is not None and target not in ROOM_ALLOWED[room]:
                violations.append(f"{path.relative_to(ROOT)}:{line} ({room}) imports {module} ({target})")
    assert not violations, "room layering broken:\n" + "\n".join(violations)


def test_sspinn_has_no_loose_modules() -> None:
    """Every module of ``sspinn`` lives in a room, except the entry points and the plumbing."""
    plumbing = {"errors", "yaml_config", "run_folder", "interrupt", "torch_files", "lazy_exports", "resource_limits"}
    loose = sorted(p.stem for p in (ROOT / "sspinn").glob("*.py") if p.stem not in TOP | plumbing)
    assert not loose, f"modules outside a room: {loose}"


def test_the_checker_sees_imports_inside_functions(tmp_path: Path) -> None:
    source = tmp_path / "module.py"
    source.write_text("import numpy\n\ndef f():\n    from agents.train import train\n    import envs.task\n")
    assert imported_packages(source) == {"agents": 4, "envs": 5}

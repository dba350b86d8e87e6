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


def test_the_checker_sees_imports_inside_functions(tmp_path: Path) -> None:
    source = tmp_path / "module.py"
    source.write_text("import numpy\n\ndef f():\n    from agents.train import train\n    import envs.task\n")
    assert imported_packages(source) == {"agents": 4, "envs": 5}

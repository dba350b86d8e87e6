"""Every module of the packages is product: a user's command or the public API reaches it.

A module that only ``benchmarks/``, ``scripts/`` or ``tests/`` import is a study or a test helper
and belongs there (``benchmarks/studies/``, ``benchmarks/accuracy/``, :mod:`sspinn.testing`), not
in the installed packages. The check: every module of ``sspinn``, ``envs``, ``agents`` and
``predictive`` (packages' ``__init__`` aside) is imported by another module of those packages —
by an import statement anywhere in the file, or named as a string (lazy exports, Gymnasium entry
points) — or is on :data:`ALLOWED` with the reason it is kept.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sspinn", "envs", "agents", "predictive")

#: modules that no other product module imports, kept for a reason
ALLOWED: dict[str, str] = {
    "sspinn.__main__": "entry point: python -m sspinn",
    "predictive.__main__": "entry point: python -m predictive",
    "agents.__main__": "entry point: python -m agents",
    "sspinn.model.codegen": "entry point: python -m sspinn.model.codegen (make generate) regenerates sspinn/model/_generated",
    "sspinn.testing": "test data for users' and the project's tests, as numpy.testing (public, documented)",
    "sspinn.testing.perturbations": "test data: perturbed recordings for the signal checks' tests",
    "sspinn.testing.sensor_mounting": "test data: synthetic 3D sensors with known mountings for the calibration's tests",
}


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def product_files() -> dict[str, Path]:
    files = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if "_generated" not in path.parts:
                files[module_name(path)] = path
    return files


def imported_names(path: Path) -> set[str]:
    """Dotted names imported in ``path`` (``from a.b import c`` gives ``a.b`` and ``a.b.c``), and
    every string constant that looks like a dotted name (``"pkg.mod"``, ``"pkg.mod:Class"``)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names |= {node.module} | {f"{node.module}.{alias.name}" for alias in node.names}
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.split(".")[0] in PACKAGES + ("benchmarks",):
            names.add(node.value.split(":")[0])
    return names


def unused_modules() -> list[str]:
    files = product_files()
    users: dict[str, set[str]] = {name: set() for name in files}
    for importer, path in files.items():
        for name in imported_names(path):
            if name in users and name != importer:
                users[name].add(importer)
    packages = {name for name, path in files.items() if path.name == "__init__.py"}
    return sorted(name for name, by in users.items() if not by and name not in packages)


def test_every_module_is_imported_by_the_product_or_allowed() -> None:
    unused = [name for name in unused_modules() if name not in ALLOWED]
    assert not unused, ("modules that only benchmarks/, scripts/ or tests/ import (move them to benchmarks/ or "
                        f"sspinn.testing, or add them to ALLOWED with a reason): {unused}")


def test_the_allow_list_names_only_modules_that_need_it() -> None:
    files, unused = product_files(), set(unused_modules())
    stale = [name for name in ALLOWED if name not in files or (name not in unused and not files[name].name == "__init__.py")]
    assert not stale, f"ALLOWED entries that are gone or now imported by the product: {stale}"


def test_no_package_imports_the_measurements_or_the_tests() -> None:
    """``benchmarks``, ``scripts``, ``examples`` and ``tests`` are not installed: the packages never import them."""
    outside = ("benchmarks", "scripts", "examples", "tests")
    found = [f"{module} imports {name}" for module, path in product_files().items()
             for name in imported_names(path) if name.split(".")[0] in outside]
    assert not found, found


def test_the_check_sees_a_module_nobody_imports(tmp_path: Path) -> None:
    source = tmp_path / "m.py"
    source.write_text('import sspinn.a\nfrom predictive.b import c\nX = "envs.d:Env"\n\ndef f():\n    import agents.e\n')
    assert imported_names(source) == {"sspinn.a", "predictive.b", "predictive.b.c", "envs.d", "agents.e"}

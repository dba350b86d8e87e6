"""Every package declares its public names in ``__all__``, and every one of them resolves; importing
the top-level packages stays light (their names are imported on first use)."""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGES = (
    "sspinn", "sspinn.model", "sspinn.data", "sspinn.imu", "sspinn.estimator", "envs", "agents", "agents.diff", "predictive",
    "predictive.ocp", "predictive.synth", "predictive.generator",
)


@pytest.mark.parametrize("package", PACKAGES)
def test_every_name_in_all_resolves(package: str) -> None:
    module = importlib.import_module(package)
    names = getattr(module, "__all__", None)
    assert names, f"{package} declares no __all__"
    assert len(names) == len(set(names)), f"{package}.__all__ repeats a name"
    missing = [name for name in names if getattr(module, name, None) is None]
    assert not missing, f"{package}.__all__ names that do not resolve: {missing}"
    assert set(names) <= set(dir(module))


@pytest.mark.parametrize("package", PACKAGES)
def test_no_public_name_is_shadowed_by_a_sub_module(package: str) -> None:
    """Importing ``package.x`` sets the attribute ``x`` of the package to that module: a public
    name ``x`` that is not that module would change meaning once anything imports it."""
    module = importlib.import_module(package)
    folder = Path(module.__file__).parent
    submodules = {p.stem for p in folder.glob("*.py")} | {p.parent.name for p in folder.glob("*/__init__.py")}
    shadowed = [name for name in module.__all__ if name in submodules
                and getattr(module, name) is not importlib.import_module(f"{package}.{name}")]
    assert not shadowed, f"{package}.__all__ names that are also sub-modules: {shadowed}"


def test_an_unknown_name_is_an_attribute_error() -> None:
    import sspinn.model

    with pytest.raises(AttributeError, match="has no attribute 'nothing'"):
        sspinn.model.nothing  # noqa: B018


@pytest.mark.parametrize(("package", "heavy"), [("sspinn", ("torch", "casadi", "numpy")), ("sspinn.model", ("torch", "casadi")),
                                                ("predictive", ("torch", "casadi")), ("agents", ("torch", "stable_baselines3"))])
def test_importing_a_package_imports_no_heavy_library(package: str, heavy: tuple[str, ...]) -> None:
    code = f"import sys, {package}; print(' '.join(m for m in {heavy!r} if m in sys.modules))"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert not loaded, f"import {package} imported {loaded}"

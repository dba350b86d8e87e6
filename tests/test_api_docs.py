"""scripts/build_api_docs.py names every public module once, and leaves out private ones and entry points."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _script():
    spec = importlib.util.spec_from_file_location("build_api_docs_script", ROOT / "scripts" / "build_api_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_public_modules_leave_out_private_modules_and_entry_points() -> None:
    script = _script()
    modules = script.public_modules(("sspinn", "envs"))
    assert "sspinn.estimator.sspinnpose" in modules and "envs.sagittal_walker" in modules
    assert not [m for m in modules if any(part.startswith("_") for part in m.split("."))]


def test_pdoc_arguments_reach_every_module_exactly_once() -> None:
    script = _script()
    modules = script.public_modules(("sspinn", "envs"))
    named = script.pdoc_arguments(modules)
    assert set(named) <= set(modules) and {"sspinn", "envs"} <= set(named)
    # sspinn and envs export names in __all__, so pdoc does not reach their submodules by itself
    assert "sspinn.model" in named and "envs.vector" in named
    # a package without __all__ reaches its submodules: they are not named again
    assert "sspinn.model.dynamics" not in named
    for module in set(modules) - set(named):
        # pdoc reaches it from one named module: naming both would leave only that one named
        assert any(module.startswith(f"{p}.") and script.pdoc_arguments([p, module]) == [p] for p in named), module

"""The scripts of ``examples/`` run with their tiny settings (``--quick``), and use only public names:
every ``sspinn.``/``envs.``/``agents.``/``predictive.`` name they read is in its package's ``__all__``."""

from __future__ import annotations

import ast
import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
#: the packages whose names examples may use (their ``__all__`` says which)
PACKAGES = ("sspinn", "sspinn.model", "sspinn.data", "sspinn.imu", "sspinn.estimator", "envs", "agents", "agents.diff", "predictive",
            "predictive.ocp", "predictive.synth", "predictive.generator")
#: example → (arguments, expected words in its output, slow); slow: more than ~10 s on one core
RUNS = {
    "estimate_from_recording.py": ([], "right knee angle", False),
    "adapt_to_subject.py": (["--quick"], "adapted for 3 steps", False),
    "walker_rollout.py": (["--quick"], "4 walkers × 20 steps", False),
    "train_ppo.py": (["--quick"], "128 training steps", True),
    "solve_gait.py": (["--quick"], "Solve_Succeeded", False),
}


def test_every_example_is_run_here() -> None:
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == sorted(RUNS)


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if RUNS[n][2] else n for n in RUNS])
def test_example_runs(name: str, tmp_path: Path) -> None:
    args, expected, _ = RUNS[name]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, str(EXAMPLES / name), *args], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert expected in done.stdout, done.stdout


def public_names_used(path: Path) -> list[tuple[str, str]]:
    """(package, name) for every project name the script reads: ``pkg.name`` chains after
    ``import pkg`` and ``from pkg import name``; a module that is not one of :data:`PACKAGES` is
    reported as (module, "") (examples import packages only)."""
    used: list[tuple[str, str]] = []
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            used += [(a.name, "") for a in node.names if a.name.split(".")[0] in ("sspinn", "envs", "agents", "predictive")
                     and a.name not in PACKAGES]
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in ("sspinn", "envs", "agents", "predictive"):
            used += [(node.module, a.name) for a in node.names] if node.module in PACKAGES else [(node.module, "")]
        elif isinstance(node, ast.Attribute):  # inner chains give the same names again
            chain, value = [node.attr], node.value
            while isinstance(value, ast.Attribute):
                chain.insert(0, value.attr)
                value = value.value
            if isinstance(value, ast.Name) and value.id in ("sspinn", "envs", "agents", "predictive"):
                package = value.id
                for part in chain:
                    if f"{package}.{part}" in PACKAGES:
                        package = f"{package}.{part}"
                        continue
                    used.append((package, part))
                    break
    return used


@pytest.mark.parametrize("name", sorted(RUNS))
def test_examples_use_only_public_names(name: str) -> None:
    missing = []
    for package, attribute in public_names_used(EXAMPLES / name):
        if package not in PACKAGES or attribute not in importlib.import_module(package).__all__:
            missing.append(f"{package}.{attribute}" if attribute else package)
    assert not missing, f"{name} uses names outside the packages' __all__: {sorted(set(missing))}"


def test_the_name_check_sees_private_names(tmp_path: Path) -> None:
    script = tmp_path / "x.py"
    script.write_text("import sspinn\nimport sspinn.estimator.training\nfrom predictive.ocp import solve_predictive\n"
                      "sspinn.model.dynamics.mass_matrix\nsspinn.SSPINNpose.load\n")
    assert set(public_names_used(script)) == {("sspinn.estimator.training", ""), ("predictive.ocp", "solve_predictive"),
                                              ("sspinn.model", "dynamics"), ("sspinn", "SSPINNpose")}


def test_the_readme_uses_only_public_names(tmp_path: Path) -> None:
    """The README's Python blocks and every dotted project name in its backticks (the task table)
    use only names in the packages' ``__all__``."""
    import re

    text = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    code = "\n".join(re.findall(r"```python\n(.*?)```", text, flags=re.S))
    dotted = re.findall(r"`((?:sspinn|envs|agents|predictive)(?:\.\w+)+)`", text)
    script = tmp_path / "readme.py"
    script.write_text(code + "\nimport sspinn, envs, agents, predictive\n" + "\n".join(dotted) + "\n")
    assert dotted, "the README names no project API (the check would pass on anything)"
    missing = [f"{p}.{a}" if a else p for p, a in public_names_used(script)
               if p not in PACKAGES or a not in importlib.import_module(p).__all__]
    assert not missing, f"README.md uses names outside the packages' __all__: {sorted(set(missing))}"

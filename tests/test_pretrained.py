"""The shipped pretrained model loads and reproduces its recorded outputs on the shipped example,
and the README's Python quickstart runs as written."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sspinn

ROOT = Path(__file__).resolve().parents[1]
PRETRAINED = ROOT / "models" / "pretrained"
QUICKSTART_HEADING = "Five minutes of Python"


def test_the_pretrained_model_reproduces_its_recorded_outputs() -> None:
    est = sspinn.SSPINNpose.load(PRETRAINED / "model.pt")
    [example] = sspinn.open_recordings(next(PRETRAINED.glob("example_*.csv")))
    assert example.labels is None
    estimate = est.predict(example)
    reference = np.load(PRETRAINED / "reference_outputs.npz")
    for name in reference.files:
        got, want = getattr(estimate, name), reference[name]
        # float32 network: other CPUs' vector units may round differently in the last bits
        scale = max(float(np.abs(want).max()), 1e-6)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-4 * scale, err_msg=name)
    assert "trained by:" in (PRETRAINED / "README.md").read_text()


def readme_quickstart() -> str:
    text = (ROOT / "README.md").read_text()
    section = text.split(f"## {QUICKSTART_HEADING}", 1)[1]
    match = re.search(r"```python\n(.*?)```", section, re.S)
    assert match, f"no python block under '## {QUICKSTART_HEADING}'"
    return match.group(1)


@pytest.mark.slow
def test_the_readme_quickstart_runs_as_written() -> None:
    code = readme_quickstart()
    assert "sspinn.SSPINNpose.load(" in code and ".predict(" in code
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]

"""Smoke test of benchmarks/bench_env.py: the quick run completes and prints its tables.

No timing assertions: the speed targets are printed by the benchmark, never asserted in tests.
"""

from __future__ import annotations

import json
import runpy
from pathlib import Path

import pytest
import torch

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_env.py"


@pytest.fixture()
def torch_threads():
    """The benchmark sets torch's thread count; restore it for the other tests."""
    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)


def test_quick_env_benchmark_prints_tables(tmp_path: Path, capsys: pytest.CaptureFixture[str], torch_threads) -> None:
    bench = runpy.run_path(str(BENCHMARK), run_name="bench_env")
    json_path = tmp_path / "bench.json"
    results = bench["main"](["--quick", "--json", str(json_path)])
    out = capsys.readouterr().out
    for text in ("Single environment", "SagittalWalker-v0 (gymnasium.make)", "Walker2d-v5", "Batched torch environment",
                 "≥ 100×", "sspinn.simulation.advance"):
        assert text in out
    assert results["single"]["rates"]["SagittalWalker-v0 (gymnasium.make)"] > 0
    assert all(r["env_steps_per_s"] > 0 for r in results["batched"].values())
    assert json.loads(json_path.read_text())["batch"] == results["batch"]

"""Smoke test of benchmarks/bench_dynamics.py: the quick run completes and prints its table.

No timing assertions: speed targets belong in the benchmark's output, never in tests.
"""

from __future__ import annotations

import json
import runpy
from pathlib import Path

import pytest
import torch

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_dynamics.py"


@pytest.fixture()
def torch_threads():
    """The benchmark sets torch's thread count; restore it for the other tests."""
    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)


def test_quick_benchmark_prints_table(tmp_path: Path, capsys: pytest.CaptureFixture[str], torch_threads) -> None:
    bench = runpy.run_path(str(BENCHMARK), run_name="bench_dynamics")
    json_path = tmp_path / "bench.json"

    results = bench["main"](["--quick", "--json", str(json_path)])

    out = capsys.readouterr().out
    for text in ("Kane residual", "naive [states/s]", "ours/naive", "target: ours ≥ 3× naive", "evals/s"):
        assert text in out
    for label in bench["LABELS"].values():
        assert label in out
    assert all(row.rate > 0 for row in results.rows)
    # the fast paths compute the same thing as the naive baselines
    assert all(row.max_deviation is None or row.max_deviation < 1e-4 for row in results.rows)

    saved = json.loads(json_path.read_text())
    assert saved["settings"]["mode"] == "quick"
    assert {row["method"] for row in saved["rows"]} >= {"naive", "ours", "forward_dynamics"}

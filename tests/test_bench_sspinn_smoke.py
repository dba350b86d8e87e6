"""Smoke run of benchmarks/bench_sspinn.py (no timing assertions: speed targets live in the benchmark)."""

from __future__ import annotations

import json
import runpy
from pathlib import Path

import torch


def test_bench_sspinn_quick(tmp_path, capsys):
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_sspinn.py"
    threads = torch.get_num_threads()
    main = runpy.run_path(str(script))["main"]
    result = main(["--quick", "--json", str(tmp_path / "r.json")])
    torch.set_num_threads(threads)
    out = capsys.readouterr().out
    assert "streaming latency" in out and "training throughput" in out
    assert result["streaming"]["ours_ms"][0] > 0 and result["training"]["sspinn_windows_per_s"] > 0
    assert json.loads((tmp_path / "r.json").read_text())["quick"] is True

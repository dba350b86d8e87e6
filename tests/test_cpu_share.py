"""Training's thread count: fixed when asked, else the CPUs that other work leaves free."""

from __future__ import annotations

import pytest
import torch

from sspinn.estimator import cpu_share
from sspinn.estimator.cpu_share import ThreadShare, free_cpus, usable_cpus


def test_a_fixed_count_is_kept() -> None:
    before = torch.get_num_threads()
    try:
        share = ThreadShare(1, every=2)
        share.update(2)
        assert share.current == 1 and torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)


@pytest.mark.parametrize(("busy_share", "expected"), [(0.0, 4), (0.25, 3), (0.5, 2), (1.0, 1)])
def test_busy_cpus_of_other_work_are_left_to_it(monkeypatch: pytest.MonkeyPatch, busy_share: float, expected: int) -> None:
    monkeypatch.setattr(cpu_share.psutil, "cpu_percent", lambda interval: busy_share * 100.0)
    monkeypatch.setattr(cpu_share, "usable_cpus", lambda: 4)
    monkeypatch.setattr(cpu_share.psutil, "cpu_count", lambda: 4)
    assert free_cpus(interval_s=0.0) == expected


def test_auto_re_measures_every_few_steps(monkeypatch: pytest.MonkeyPatch) -> None:
    answers = iter([2, 1])
    monkeypatch.setattr(cpu_share, "free_cpus", lambda interval_s=0.2: next(answers))
    before = torch.get_num_threads()
    try:
        share = ThreadShare(0, every=10)
        assert share.current == 2
        share.update(5)  # not a multiple of every: no measurement
        assert share.current == 2
        share.update(10)
        assert share.current == 1 and torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)


def test_the_real_measurement_is_in_range() -> None:
    assert 1 <= free_cpus(interval_s=0.05) <= usable_cpus()

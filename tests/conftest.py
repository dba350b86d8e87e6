"""Shared fixtures: a default body, random states, and the location of ../shared/data."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.contact import ContactParameters

#: ../shared/data beside the repository; ``SSPINN_SHARED_DATA`` points elsewhere (a worktree in another folder).
SHARED_DATA = Path(os.environ.get("SSPINN_SHARED_DATA") or Path(__file__).resolve().parents[1].parent / "shared" / "data")
# the library finds the optional public data only where it is told (sspinn.data.shared_data): tell it
os.environ.setdefault("SSPINN_SHARED_DATA", str(SHARED_DATA))


@pytest.fixture(scope="session")
def body() -> BodyParameters:
    return BodyParameters.from_anthropometry(1.75, 70.0)


@pytest.fixture(scope="session")
def contact() -> ContactParameters:
    return ContactParameters()


@pytest.fixture(scope="session")
def imu() -> IMUPlacement:
    return IMUPlacement.default(1.75)


@pytest.fixture()
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)


def shared_data(name: str) -> Path:
    """Path of a ../shared/data folder, or skip the test with a clear message."""
    path = SHARED_DATA / name
    if not path.exists():
        pytest.skip(f"real data {path} not present (../shared/data is optional; CI provides it)")
    return path


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory):
    """A tiny dataset, a tiny training config and a finished 4-step run: (root, data folder,
    config path, training recordings, run folder); see :func:`sspinn.testing.tiny_run`."""
    from sspinn.data.dataset import Dataset
    from sspinn.testing import tiny_run

    root = tmp_path_factory.mktemp("tiny_run")
    data, cfg, run = tiny_run(root)
    return root, data, cfg, Dataset.open(data).load("train"), run


@pytest.fixture()
def torch_threads():
    """Restores torch's thread count after a test that sets it (the benchmarks do)."""
    import torch

    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)


@pytest.fixture(scope="session")
def small_generator(tmp_path_factory) -> Path:
    """An untrained gait generator (2 harmonics, 8 units) whose file says it was trained on
    1.0–1.5 m/s, 1.6–1.9 m and 55–90 kg: ``generate`` runs in well under a second."""
    from predictive.generator.gait_generator import GaitGeneratorNet, GeneratorConfig, save_generator

    config = GeneratorConfig(speeds=(1.0, 1.5), harmonics=2, hidden=8, layers=1)
    path = tmp_path_factory.mktemp("generator") / "generator.pt"
    save_generator(GaitGeneratorNet(2, 8, 1).double(), path, config, wall_s=1.0)
    return path

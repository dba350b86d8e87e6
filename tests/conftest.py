"""Shared fixtures: a default body, random states, and the location of ../shared/data."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sspinn.body import BodyParameters, IMUPlacement
from sspinn.contact import ContactParameters

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


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


def random_inputs(rng: np.random.Generator, batch: tuple[int, ...] = ()) -> dict[str, np.ndarray]:
    """Random but plausible model inputs (SI units) with leading ``batch`` dimensions."""
    q = rng.normal(scale=0.5, size=batch + (9,))
    q[..., 1] = rng.uniform(0.85, 1.0, size=batch)  # hip height near standing
    return {
        "q": q,
        "u": rng.normal(scale=2.0, size=batch + (9,)),
        "qdd": rng.normal(scale=10.0, size=batch + (9,)),
        "tau": rng.normal(scale=50.0, size=batch + (6,)),
        "grf": rng.normal(scale=300.0, size=batch + (4,)),
        "w": rng.uniform(size=batch + (2,)),
        "mu_hat": rng.normal(size=batch + (2,)),
        "ankle": rng.normal(scale=0.1, size=batch + (8,)),
    }


def shared_data(name: str) -> Path:
    """Path of a ../shared/data folder, or skip the test with a clear message."""
    path = SHARED_DATA / name
    if not path.exists():
        pytest.skip(f"real data {path} not present (../shared/data is optional; CI provides it)")
    return path


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory):
    """A tiny dataset, a tiny training config and a finished 4-step run: (root, data folder,
    config path, training recordings, run folder)."""
    import yaml

    from sspinn.dataset import Dataset
    from sspinn.training import TrainConfig, Trainer
    from tests.test_dataset import make_recording

    root = tmp_path_factory.mktemp("tiny_run")
    rng = np.random.default_rng(3)
    data = root / "data"
    Dataset.write(data, {"train": [make_recording("a", "s1", 150, rng), make_recording("b", "s2", 150, rng)],
                         "test": [make_recording("c", "s3", 120, rng)]})
    cfg = root / "tiny.yaml"
    cfg.write_text(yaml.safe_dump({"train": {
        "network": {"hidden": 8, "layers": 1, "dropout": 0.0, "dense": 8}, "steps": 4, "batch_size": 2, "window": 32,
        "log_every": 1, "checkpoint_every": 2, "device": "cpu",
    }}))
    train = Dataset.open(data).load("train")
    run = root / "run"
    Trainer(TrainConfig.from_yaml(cfg), run).fit(train)
    return root, data, cfg, train, run


@pytest.fixture()
def torch_threads():
    """Restores torch's thread count after a test that sets it (the benchmarks do)."""
    import torch

    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)

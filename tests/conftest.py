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

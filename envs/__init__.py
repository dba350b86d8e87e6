"""Gymnasium environments of the sspinn sagittal model.

Importing this package registers ``"sspinn/SagittalWalker-v0"`` (:class:`SagittalWalkerEnv`), so::

    import envs  # noqa: F401  (registers the environment)
    import gymnasium

    env = gymnasium.make("sspinn/SagittalWalker-v0", render_mode="rgb_array")

or, without the explicit import, ``gymnasium.make("envs:sspinn/SagittalWalker-v0")`` (Gymnasium
imports the module named before the colon). Gymnasium ≥ 1.0 removed the automatic plugin
discovery through the ``gymnasium.envs`` entry-point group that Gym 0.22–0.26 had, so an entry
point in ``pyproject.toml`` would not be read; one of these two forms is needed.

The batched torch version is :class:`envs.batched.BatchedSagittalWalker` (imported lazily, so that
``import envs`` does not import torch).
"""

from __future__ import annotations

from typing import Any

from gymnasium.envs.registration import register, registry

ENV_ID = "sspinn/SagittalWalker-v0"


def register_envs() -> None:
    """Register the environments with Gymnasium (idempotent)."""
    if ENV_ID not in registry:
        register(id=ENV_ID, entry_point="envs.sagittal_walker:SagittalWalkerEnv")


register_envs()


def __getattr__(name: str) -> Any:
    if name == "SagittalWalkerEnv":
        from envs.sagittal_walker import SagittalWalkerEnv

        return SagittalWalkerEnv
    if name == "BatchedSagittalWalker":
        from envs.batched import BatchedSagittalWalker

        return BatchedSagittalWalker
    raise AttributeError(f"module 'envs' has no attribute {name!r}")


__all__ = ["ENV_ID", "BatchedSagittalWalker", "SagittalWalkerEnv", "register_envs"]

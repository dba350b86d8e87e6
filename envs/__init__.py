"""Gymnasium environments of the sspinn sagittal model.

Importing this package registers ``"sspinn/SagittalWalker-v0"`` (:class:`SagittalWalkerEnv`), so::

    import envs  # noqa: F401  (registers the environment)
    import gymnasium

    env = gymnasium.make("sspinn/SagittalWalker-v0", render_mode="rgb_array")

or, without the explicit import, ``gymnasium.make("envs:sspinn/SagittalWalker-v0")`` (Gymnasium
imports the module named before the colon). Gymnasium ≥ 1.0 removed the automatic plugin
discovery through the ``gymnasium.envs`` entry-point group that Gym 0.22–0.26 had, so an entry
point in ``pyproject.toml`` would not be read; one of these two forms is needed.

The registration declares ``max_episode_steps=1000``, the environment's own episode length
(``gymnasium.make`` adds a ``TimeLimit`` at the same step), and the native vector environment
:class:`envs.vector.SagittalWalkerVectorEnv` as its vector entry point::

    vec = gymnasium.make_vec("sspinn/SagittalWalker-v0", num_envs=64, vectorization_mode="vector_entry_point")

The batched torch version (differentiable, CPU or GPU) is :class:`envs.batched.BatchedSagittalWalker`
(imported lazily, so that ``import envs`` does not import torch).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gymnasium.envs.registration import register, registry

from sspinn.lazy_exports import attach

ENV_ID = "sspinn/SagittalWalker-v0"
#: Episode length of the registration, control steps: ``WalkerConfig().max_episode_steps`` (not
#: imported here, so that ``import envs`` stays light; ``tests/test_vector_env.py`` checks it).
MAX_EPISODE_STEPS = 1000


def register_envs() -> None:
    """Register the environments with Gymnasium (idempotent)."""
    if ENV_ID not in registry:
        register(
            id=ENV_ID,
            entry_point="envs.sagittal_walker:SagittalWalkerEnv",
            vector_entry_point="envs.vector:SagittalWalkerVectorEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
        )


register_envs()


#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    "SagittalWalkerEnv": "envs.sagittal_walker",
    "SagittalWalkerVectorEnv": "envs.vector",
    "BatchedSagittalWalker": "envs.batched",
    "WalkerConfig": "envs.config",
}
if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from envs.batched import BatchedSagittalWalker
    from envs.config import WalkerConfig
    from envs.sagittal_walker import SagittalWalkerEnv
    from envs.vector import SagittalWalkerVectorEnv

__getattr__, __dir__ = attach(__name__, _EXPORTS)

__all__ = [
    "ENV_ID", "MAX_EPISODE_STEPS", "BatchedSagittalWalker", "SagittalWalkerEnv", "SagittalWalkerVectorEnv", "WalkerConfig",
    "register_envs",
]

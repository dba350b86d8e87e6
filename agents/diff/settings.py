"""Settings of the controllers that learn through the differentiable simulator (:mod:`agents.diff`).

They are the ``hyperparameters`` section of an agent configuration whose ``algo`` is ``apg``,
``shac`` or ``ahac`` (``configs/agents/shac_walk.yaml``), checked by the project's configuration
loader (types, ranges with upper bounds) so that a bad value is one line naming the key and its
bounds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from sspinn.yaml_config import config_from_mapping, option

if TYPE_CHECKING:
    from agents.config import AgentConfig

__all__ = ["DIFF_ACTIVATIONS", "MAX_ENVS", "MAX_HORIZON", "DiffSettings", "settings_of"]
#: Most parallel walkers a differentiable window holds (the autograd graph of every substep is kept).
MAX_ENVS = 4096
#: Most control steps in one differentiable window.
MAX_HORIZON = 256
#: Activation functions of the actor and critic MLPs (name → ``torch.nn`` class name).
DIFF_ACTIVATIONS: dict[str, str] = {"elu": "ELU", "tanh": "Tanh", "relu": "ReLU"}


@dataclass(frozen=True)
class DiffSettings:
    """Hyperparameters of APG, SHAC and AHAC (:class:`agents.diff.agent.DiffAgent`).

    Attributes:
        horizon: control steps (0.01 s each) per differentiable window, 1–256. APG backpropagates
            the discounted return of the window alone; SHAC and AHAC close it with the critic.
        gamma: discount factor per control step, (0, 1].
        lam: λ of the critic's TD(λ) targets, [0, 1].
        actor_lr: Adam learning rate of the actor (linearly decayed to ``lr_final_share`` of it).
        critic_lr: Adam learning rate of the critic (same decay).
        lr_final_share: learning rate at the end of the budget as a share of the initial one, [0, 1].
        max_grad_norm: the actor's gradient is clipped to this L2 norm (the window loss is a mean
            over walkers and steps).
        critic_iterations: epochs of critic regression per window, 1–256.
        critic_batches: minibatches per epoch, 1–64.
        target_alpha: Polyak factor of the target critic, target ← α·target + (1 − α)·critic, [0, 1).
        init_log_std: initial log standard deviation of the actor's exploration noise (before tanh).
        actor_hidden: hidden layer sizes of the actor MLP (each 1–1024, at most 4 layers).
        critic_hidden: hidden layer sizes of the critic MLP (each 1–1024, at most 4 layers).
        activation: hidden activation, one of :data:`DIFF_ACTIVATIONS`.
        cut_grf_rate: (AHAC) a walker's window is cut (its state detached, the critic closes the
            piece before) at a control step where its ground reaction force changes by more than this
            many body weights: the stiff contact events where the gradient through the physics
            explodes. Ignored by APG and SHAC.
    """

    horizon: int = option(32, ge=1, le=MAX_HORIZON)
    gamma: float = option(0.99, gt=0, le=1)
    lam: float = option(0.95, ge=0, le=1)
    actor_lr: float = option(2e-3, gt=0, le=1)
    critic_lr: float = option(2e-3, gt=0, le=1)
    lr_final_share: float = option(0.1, ge=0, le=1)
    max_grad_norm: float = option(1.0, gt=0, le=1e6)
    critic_iterations: int = option(16, ge=1, le=256)
    critic_batches: int = option(4, ge=1, le=64)
    target_alpha: float = option(0.2, ge=0, le=0.999)
    init_log_std: float = option(-1.0, ge=-5, le=1)
    actor_hidden: tuple[int, ...] = (128, 64, 32)
    critic_hidden: tuple[int, ...] = (64, 64)
    activation: str = option("elu", choices=DIFF_ACTIVATIONS)
    cut_grf_rate: float = option(2.0, gt=0, le=100, unit="BW per step")

    def __post_init__(self) -> None:
        for name in ("actor_hidden", "critic_hidden"):
            sizes = getattr(self, name)
            if not 1 <= len(sizes) <= 4 or not all(isinstance(h, int) and 1 <= h <= 1024 for h in sizes):
                raise ValueError(f"{name} must be 1–4 layer sizes, each an integer in [1, 1024], got {list(sizes)}")


def settings_of(config: AgentConfig, source: str = "config") -> DiffSettings:
    """The :class:`DiffSettings` in a configuration's ``hyperparameters`` (checked, one-line errors)."""
    return config_from_mapping(DiffSettings, config.hyperparameters, source, what="key", prefix="hyperparameters")

"""APG, SHAC and AHAC: policies learned by backpropagating the return through the simulator.

All three roll out ``n_envs`` walkers of :class:`envs.batched.BatchedSagittalWalker` (torch, nothing
detached) for a window of ``horizon`` control steps under a tanh-squashed Gaussian policy
(reparameterised samples, so the actions are differentiable functions of the policy's parameters),
take the window's discounted reward and follow its gradient through the 50-substep physics:

* **APG** — analytic policy gradient by truncated backpropagation through time: the loss of a window
  is minus its discounted return, nothing beyond the window (the baseline of Brax's ``apg``:
  Freeman et al. 2021, "Brax — a differentiable physics engine for large scale rigid body
  simulation").
* **SHAC** — Short-Horizon Actor-Critic (Xu et al., ICLR 2022, "Accelerated Policy Learning with
  Parallel Differentiable Simulation"): the window's return is closed by γ^h·V(s_h) of a learned
  critic (its target copy), so a short window sees the long-run value; episodes that terminate
  inside the window close there with no bootstrap (with V of the final observation when truncated
  by the time limit); the critic regresses TD(λ) targets of the window's (detached) rewards, and a
  Polyak-averaged target critic supplies the bootstrap values. Loss normalised by N·h, the actor's
  gradient clipped, learning rates decayed linearly.
* **AHAC** — adaptive horizon (after Georgiev et al., ICML 2024, "Adaptive Horizon Actor-Critic for
  Policy Learning in Contact-Rich Differentiable Simulation"): SHAC whose window is cut, walker by
  walker, at the stiff contact events where the gradient through the physics explodes. The paper
  adapts the horizon from the contact stiffness; here the measure is the contact force rate —
  a walker whose vertical ground reaction force changes by more than ``cut_grf_rate`` body weights
  in one control step (a foot strike) has its window closed there by the critic and its state
  detached, and it continues in a new piece. This is a simplification of the paper's
  constrained-horizon rule, said plainly.

Reward and termination are the environment's own (:func:`envs.task.reward`, computed in torch by the
batched environment). Differentiable terms: speed tracking, effort, and the contact shaping (foot
slip through the friction law's artanh, impact above the threshold). Piecewise-constant terms with
zero gradient almost everywhere: the alive bonus (an indicator of not falling) and the phase penalty
(indicators of phase durations); they still enter the critic's targets, which is how SHAC and AHAC
see them (APG does not). Termination is not differentiable: a walker that falls closes its piece.

Observations are normalised by running mean and variance (updated from the rollouts, frozen in
:meth:`DiffAgent.predict`), the idea of SB3's VecNormalize used by the PPO recipes; rewards are not
normalised. No gait prior or clock is used by these agents.

Gradient health is recorded per window (:attr:`DiffAgent.history`): the actor's gradient norm
before clipping, whether it was clipped, the norm of the loss's gradient with respect to the first
and the last action of the window (their ratio shows how the gradient grows backward through the
contacts), the running variance of the gradient vector across windows, and AHAC's cut rate.

The class follows the shape of SB3: ``DiffAgent(algo, settings, ...)`` → :meth:`learn` →
:meth:`predict` → :meth:`save` / :meth:`load` (``torch.save`` of tensors and plain data, read back
with ``weights_only=True`` through :mod:`sspinn.torch_files`: nothing loaded runs code).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from agents.config import DIFF_ALGORITHMS
from agents.diff.settings import DIFF_ACTIVATIONS, MAX_ENVS, DiffSettings
from envs.batched import BatchedSagittalWalker
from envs.config import SUBSTEPS
from envs.task import OBS_SIZE
from sspinn.model.conventions import N_TAU
from sspinn.torch_files import ModelFileError, check_finite_weights, load_torch_file, save_torch_file
from sspinn.yaml_config import ConfigError, config_from_mapping

#: The ``format`` entry of a saved agent (:mod:`sspinn.torch_files`).
DIFF_AGENT_KIND = "sspinn-diff-agent"
#: Autograd memory a window keeps per walker and physics substep, bytes: measured as the resident
#: size of a training process with 64 walkers × 16 steps × 50 substeps (8.3 GB, one CPU thread).
BYTES_PER_WALKER_SUBSTEP = 160_000
#: Largest share of the machine's physical memory one window's graph may need.
MAX_MEMORY_SHARE = 0.8
#: What to do with a file that is not a usable agent.
_HINT = "train one with `python -m agents train --config configs/agents/shac_walk.yaml --out <run>`"


def check_window_memory(n_envs: int, horizon: int, substeps: int) -> None:
    """Refuse a window whose autograd graph (≈ :data:`BYTES_PER_WALKER_SUBSTEP` per walker and
    substep, all kept until the backward pass) would need more than :data:`MAX_MEMORY_SHARE` of
    the machine's physical memory: a ``ValueError`` naming the sizes."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # not POSIX: no check
        return
    need = n_envs * horizon * substeps * BYTES_PER_WALKER_SUBSTEP
    if need > MAX_MEMORY_SHARE * total:
        raise ValueError(
            f"a window of {n_envs} walkers × {horizon} steps × {substeps} substeps keeps about {need / 1e9:.0f} GB of "
            f"autograd graph (≈ {BYTES_PER_WALKER_SUBSTEP // 1000} kB per walker-substep), more than "
            f"{MAX_MEMORY_SHARE:.0%} of this machine's {total / 1e9:.0f} GB: lower n_envs or horizon")


def mlp(sizes: list[int], activation: str) -> nn.Sequential:
    """Linear layers of ``sizes`` with ``activation`` between them (none after the last)."""
    act = getattr(nn, DIFF_ACTIVATIONS[activation])
    layers: list[nn.Module] = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        layers.append(nn.Linear(a, b))
        if i < len(sizes) - 2:
            layers.append(act())
    return nn.Sequential(*layers)


class RunningNorm(nn.Module):
    """Running mean and variance of the observations (Chan et al.'s parallel update, as SB3's
    ``RunningMeanStd``), applied as (x − mean)/√(var + ε) clipped to ± ``clip``. The statistics are
    buffers (saved with the agent); :meth:`forward` is differentiable in ``x``."""

    def __init__(self, size: int, clip: float, epsilon: float = 1e-8) -> None:
        super().__init__()
        self.clip, self.epsilon = float(clip), float(epsilon)
        self.register_buffer("mean", torch.zeros(size, dtype=torch.float64))
        self.register_buffer("var", torch.ones(size, dtype=torch.float64))
        self.register_buffer("count", torch.tensor(1e-4, dtype=torch.float64))

    @torch.no_grad()
    def update(self, x: torch.Tensor) -> None:
        """Fold a batch (n, size) into the statistics."""
        x = x.detach().to(torch.float64).reshape(-1, self.mean.numel())
        n = x.shape[0]
        mean, var = x.mean(0), x.var(0, unbiased=False)
        delta = mean - self.mean
        total = self.count + n
        self.mean += delta * n / total
        self.var.copy_((self.var * self.count + var * n + delta**2 * self.count * n / total) / total)
        self.count.fill_(float(total))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        scale = torch.sqrt(self.var + self.epsilon).to(x.dtype)
        return ((x - self.mean.to(x.dtype)) / scale).clamp(-self.clip, self.clip)


@dataclasses.dataclass
class Window:
    """One differentiable window of :meth:`DiffAgent.rollout_window` (h steps × N walkers).

    Attributes:
        loss: the actor's loss (a scalar with its autograd graph through the physics).
        obs: normalised observations the actions were taken from (h, N, 22), detached.
        rewards: the environment's rewards (h, N), detached.
        next_values: target-critic values of the next states (h, N), 0 after a termination.
        ends: an episode ended at that step (h, N).
        actions: the actions (N, 6) of each step, with their gradients kept after ``backward``.
        cuts: AHAC's cuts in the window. finished_returns, finished_distances: episodes that ended
            in the window (return; distance in m).
    """

    loss: torch.Tensor
    obs: torch.Tensor
    rewards: torch.Tensor
    next_values: torch.Tensor
    ends: torch.Tensor
    actions: list[torch.Tensor] = dataclasses.field(default_factory=list)
    cuts: int = 0
    finished_returns: list[float] = dataclasses.field(default_factory=list)
    finished_distances: list[float] = dataclasses.field(default_factory=list)


class DiffAgent:
    """A policy for the sagittal walker learned through the differentiable simulator.

    Args:
        algo: ``"apg"``, ``"shac"`` or ``"ahac"`` (see the module docstring).
        settings: the hyperparameters (:class:`~agents.diff.settings.DiffSettings`).
        n_envs: parallel walkers N of a window, 1–:data:`~agents.diff.settings.MAX_ENVS`.
        env_kwargs: fields of :class:`envs.config.WalkerConfig` for the training environment (target
            speed in m/s, reward weights, substeps, ...), plain data.
        seed: seeds the networks, the exploration noise and the environments (0 to 2³² − 1).
        obs_clip: normalised observations are clipped to ± this value (as VecNormalize's
            ``clip_obs``; the configuration's ``normalize.clip_obs``), in (0, 1000].
        config: the run's :class:`agents.config.AgentConfig` when trained by ``python -m agents
            train`` (used by ``evaluate``; not needed to learn or predict).

    Attributes:
        num_timesteps: environment steps taken in training (over all walkers).
        updates: windows (actor updates) done.
        history: one dict per window of this process (see :meth:`update_window`).
    """

    def __init__(self, algo: str, settings: DiffSettings | None = None, n_envs: int = 64,
                 env_kwargs: Mapping[str, Any] | None = None, seed: int = 0, obs_clip: float = 10.0,
                 config: Any = None) -> None:
        if algo not in DIFF_ALGORITHMS:
            raise ValueError(f"algo must be one of {', '.join(DIFF_ALGORITHMS)}, got {algo!r}")
        if isinstance(n_envs, bool) or not isinstance(n_envs, int) or not 1 <= n_envs <= MAX_ENVS:
            raise ValueError(f"n_envs must be an integer in [1, {MAX_ENVS}], got {n_envs!r}")
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
            raise ValueError(f"seed must be an integer in [0, 2**32 - 1], got {seed!r}")
        if not isinstance(obs_clip, (int, float)) or isinstance(obs_clip, bool) or not 0 < obs_clip <= 1000:
            raise ValueError(f"obs_clip must be a number in (0, 1000], got {obs_clip!r}")
        self.algo = algo
        self.settings = settings if settings is not None else DiffSettings()
        check_window_memory(n_envs, self.settings.horizon, int((env_kwargs or {}).get("substeps", SUBSTEPS)))
        self.n_envs = n_envs
        self.env_kwargs = dict(env_kwargs or {})
        self.seed = seed
        self.config = config
        s = self.settings
        torch.manual_seed(seed)
        self.actor = mlp([OBS_SIZE, *s.actor_hidden, N_TAU], s.activation)
        self.log_std = nn.Parameter(torch.full((N_TAU,), float(s.init_log_std)))
        self.obs_norm = RunningNorm(OBS_SIZE, obs_clip)
        self.critic = mlp([OBS_SIZE, *s.critic_hidden, 1], s.activation) if self.uses_critic else None
        self.target_critic = copy.deepcopy(self.critic) if self.critic is not None else None
        self.actor_opt = torch.optim.Adam([*self.actor.parameters(), self.log_std], lr=s.actor_lr, betas=(0.7, 0.95))
        self.critic_opt = (torch.optim.Adam(self.critic.parameters(), lr=s.critic_lr, betas=(0.7, 0.95))
                           if self.critic is not None else None)
        self.noise = torch.Generator()
        self.noise.manual_seed(seed)
        self.num_timesteps = 0
        self.updates = 0
        self.history: list[dict[str, float]] = []
        # running mean and summed squared deviation of the actor's gradient vector across windows (Welford)
        self.grad_mean = torch.zeros(sum(p.numel() for p in self.actor_parameters()), dtype=torch.float64)
        self.grad_m2 = torch.zeros((), dtype=torch.float64)
        self._env: BatchedSagittalWalker | None = None
        self._episode_return: torch.Tensor | None = None

    # ------------------------------------------------------------------------------------------
    @property
    def uses_critic(self) -> bool:
        """SHAC and AHAC close their windows with a critic; APG does not."""
        return self.algo != "apg"

    @property
    def initial_state(self) -> None:
        """Episodes start standing (no reference stride): ``run_episode`` resets as usual."""
        return None

    def actor_parameters(self) -> list[nn.Parameter]:
        """The parameters the window loss is differentiated for (the MLP and the log-std)."""
        return [*self.actor.parameters(), self.log_std]

    @property
    def env(self) -> BatchedSagittalWalker:
        """The training environments, made at the first window (seeded with seed + steps taken, so
        that a resumed run does not replay the first run's initial states)."""
        if self._env is None:
            env_seed = (self.seed + self.num_timesteps) % 2**63
            self._env = BatchedSagittalWalker(self.n_envs, seed=env_seed, auto_reset=True, **self.env_kwargs)
            self._env.reset()
            self._episode_return = torch.zeros(self.n_envs)
        return self._env

    def _action(self, x: torch.Tensor, deterministic: bool) -> torch.Tensor:
        mean = self.actor(x)
        if deterministic:
            return torch.tanh(mean)
        eps = torch.randn(mean.shape, generator=self.noise, dtype=mean.dtype)
        return torch.tanh(mean + torch.exp(self.log_std) * eps)

    # ------------------------------------------------------------------------------------------
    def rollout_window(self, update_statistics: bool = True) -> Window:
        """Roll out one window of ``horizon`` steps from the environments' current states with
        gradients through the physics and return its loss (to be minimised: minus the discounted
        rewards of each piece closed by the target critic's value, averaged over walkers and steps)
        and its records. ``update_statistics``: fold the observations into the running
        normalisation (False: keep it fixed, e.g. to compare two actors on the same batch)."""
        s, env, n, h = self.settings, self.env, self.n_envs, self.settings.horizon
        env.set_state(env.q.detach(), env.u.detach())  # the window starts from a constant state
        obs = env.observe()
        bw = float(env.body.body_weight)
        grf_prev = env.grf.detach()
        ret = torch.zeros(n)
        disc = torch.ones(n)
        total = torch.zeros(())
        w = Window(loss=total, obs=torch.zeros(h, n, OBS_SIZE), rewards=torch.zeros(h, n),
                   next_values=torch.zeros(h, n), ends=torch.zeros(h, n, dtype=torch.bool))
        assert self._episode_return is not None
        for t in range(h):
            if update_statistics:
                self.obs_norm.update(obs)
            x = self.obs_norm(obs)
            w.obs[t] = x.detach()
            a = self._action(x, deterministic=False)
            a.retain_grad()
            w.actions.append(a)
            obs, r, terminated, truncated, info = env.step(a)
            done = terminated | truncated
            ret = ret + disc * r
            disc = disc * s.gamma
            final_obs = torch.where(done[:, None], info["final_obs"], obs) if bool(done.any()) else obs
            if self.target_critic is not None:
                value = self.target_critic(self.obs_norm(final_obs)).squeeze(-1)
                value = torch.where(terminated, torch.zeros_like(value), value)
            else:
                value = torch.zeros(n)
            w.rewards[t], w.next_values[t], w.ends[t] = r.detach(), value.detach(), done
            closing = done.clone()
            cut = torch.zeros(n, dtype=torch.bool)
            if self.algo == "ahac":
                rate = (info["grf"].detach()[:, 1::2] - grf_prev[:, 1::2]).abs().amax(-1) / bw
                cut = (rate > s.cut_grf_rate) & ~done
                closing |= cut
                w.cuts += int(cut.sum())
            grf_prev = env.grf.detach()
            if t == h - 1:
                closing[:] = True
            total = total + torch.where(closing, ret + disc * value, torch.zeros_like(ret)).sum()
            ret = torch.where(closing, torch.zeros_like(ret), ret)
            disc = torch.where(closing, torch.ones_like(disc), disc)
            if bool(cut.any()):  # AHAC: the gradient stops at the stiff contact event
                keep = cut[:, None]
                env.set_state(torch.where(keep, env.q.detach(), env.q), torch.where(keep, env.u.detach(), env.u))
                obs = torch.where(keep, obs.detach(), obs)
            self._episode_return += r.detach()
            if bool(done.any()):
                w.finished_returns += self._episode_return[done].tolist()
                w.finished_distances += info["distance"][done].tolist()
                self._episode_return[done] = 0.0
        w.loss = -total / (n * h)
        return w

    def update_window(self, lr_share: float = 1.0) -> dict[str, float]:
        """One window (:meth:`rollout_window`), one actor step on its loss, the critic's regression
        (SHAC, AHAC); returns the window's statistics (also appended to :attr:`history`):

        ``steps`` (environment steps after it), ``loss`` (the actor's window loss), ``mean_reward``
        (per walker and step), ``grad_norm`` (the actor's gradient norm before clipping),
        ``clipped`` (1 when it exceeded ``max_grad_norm``), ``grad_first_action`` and
        ``grad_last_action`` (mean over walkers of ‖∂loss/∂a‖ at the first and the last step of
        the window, times N·h: the gradient of a walker's own window return),
        ``grad_variance`` (running variance of the gradient vector across windows, mean per
        parameter), ``cut_rate`` (AHAC: cuts per walker and step), ``critic_loss``, ``episodes``
        (finished in the window), ``episode_return`` and ``episode_distance`` (means over them; NaN
        when none finished), ``action_std`` (the exploration noise's mean std before tanh)."""
        s, n, h = self.settings, self.n_envs, self.settings.horizon
        for group in self.actor_opt.param_groups:
            group["lr"] = s.actor_lr * lr_share
        w = self.rollout_window()
        self.actor_opt.zero_grad(set_to_none=True)
        w.loss.backward()
        params = self.actor_parameters()
        flat = torch.cat([(p.grad if p.grad is not None else torch.zeros_like(p)).reshape(-1) for p in params])
        flat = flat.to(torch.float64)
        finite = bool(torch.isfinite(flat).all())
        grad_norm = float(flat.norm()) if finite else math.inf
        if finite:  # a non-finite gradient skips the actor's step
            torch.nn.utils.clip_grad_norm_(params, s.max_grad_norm)
            self.actor_opt.step()
            k = self.updates + 1  # Welford's update of the gradient's mean and variance across windows
            delta = flat - self.grad_mean
            self.grad_mean += delta / k
            self.grad_m2 += (delta * (flat - self.grad_mean)).sum()
        first, last = w.actions[0].grad, w.actions[-1].grad
        critic_loss = (self._update_critic(w.obs, w.rewards, w.next_values, w.ends, lr_share)
                       if self.critic is not None else math.nan)
        self.env.set_state(self.env.q.detach(), self.env.u.detach())
        self.num_timesteps += n * h
        self.updates += 1
        stats = {
            "steps": float(self.num_timesteps),
            "loss": float(w.loss.detach()),
            "mean_reward": float(w.rewards.mean()),
            "grad_norm": grad_norm,
            "clipped": float(grad_norm > s.max_grad_norm),
            "grad_first_action": float(first.norm(dim=-1).mean()) * n * h if first is not None else math.nan,
            "grad_last_action": float(last.norm(dim=-1).mean()) * n * h if last is not None else math.nan,
            "grad_variance": float(self.grad_m2 / max(self.updates - 1, 1) / self.grad_mean.numel()),
            "cut_rate": w.cuts / (n * h),
            "critic_loss": critic_loss,
            "episodes": float(len(w.finished_returns)),
            "episode_return": float(np.mean(w.finished_returns)) if w.finished_returns else math.nan,
            "episode_distance": float(np.mean(w.finished_distances)) if w.finished_distances else math.nan,
            "action_std": float(torch.exp(self.log_std.detach()).mean()),
        }
        self.history.append(stats)
        return stats

    def td_lambda_targets(self, rew: torch.Tensor, next_val: torch.Tensor, ends: torch.Tensor) -> torch.Tensor:
        """TD(λ) targets (h, N) of the window: G_t = r_t + γ·((1 − λ)·V(s_{t+1}) + λ·G_{t+1}), and
        G_t = r_t + γ·V(s_{t+1}) at the window's last step and where an episode ended at step t
        (V = 0 after a termination, V of the final observation after a truncation)."""
        s = self.settings
        targets = torch.zeros_like(rew)
        g = torch.zeros_like(rew[0])
        for t in reversed(range(rew.shape[0])):
            if t == rew.shape[0] - 1:
                g = rew[t] + s.gamma * next_val[t]
            else:
                blended = (1 - s.lam) * next_val[t] + s.lam * g
                g = rew[t] + s.gamma * torch.where(ends[t], next_val[t], blended)
            targets[t] = g
        return targets

    def _update_critic(self, obs: torch.Tensor, rew: torch.Tensor, next_val: torch.Tensor, ends: torch.Tensor,
                       lr_share: float) -> float:
        """Regress the critic on the window's TD(λ) targets, then move the target critic."""
        assert self.critic is not None and self.critic_opt is not None and self.target_critic is not None
        s = self.settings
        for group in self.critic_opt.param_groups:
            group["lr"] = s.critic_lr * lr_share
        x = obs.reshape(-1, OBS_SIZE)
        y = self.td_lambda_targets(rew, next_val, ends).reshape(-1)
        batches = min(s.critic_batches, len(y))
        total = 0.0
        for _ in range(s.critic_iterations):
            order = torch.randperm(len(y), generator=self.noise)
            total = 0.0
            for idx in order.chunk(batches):
                loss = ((self.critic(x[idx]).squeeze(-1) - y[idx]) ** 2).mean()
                self.critic_opt.zero_grad(set_to_none=True)
                loss.backward()
                torch.nn.utils.clip_grad_norm_(self.critic.parameters(), s.max_grad_norm)
                self.critic_opt.step()
                total += float(loss.detach()) / batches
        with torch.no_grad():
            for target, source in zip(self.target_critic.parameters(), self.critic.parameters()):
                target.mul_(s.target_alpha).add_((1 - s.target_alpha) * source)
        return total

    def learn(self, total_env_steps: int, callback: Callable[[DiffAgent, dict[str, float]], bool] | None = None) -> DiffAgent:
        """Update window after window until :attr:`num_timesteps` reaches ``total_env_steps``
        (environment steps over all walkers, at most 10¹¹). ``callback(agent, stats)`` runs after
        every window; returning False stops. Learning rates decay linearly over ``total_env_steps``."""
        if isinstance(total_env_steps, bool) or not isinstance(total_env_steps, int) or not 1 <= total_env_steps <= 10**11:
            raise ValueError(f"total_env_steps must be an integer in [1, 1e11], got {total_env_steps!r}")
        final = self.settings.lr_final_share
        while self.num_timesteps < total_env_steps:
            share = 1.0 - (1.0 - final) * min(self.num_timesteps / total_env_steps, 1.0)
            stats = self.update_window(share)
            if callback is not None and callback(self, stats) is False:
                break
        return self

    # ------------------------------------------------------------------------------------------
    @torch.no_grad()
    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        """SB3's convention: action(s) in [−1, 1] for an observation (22,) or a batch (n, 22) and the
        state to pass back (always None: the policy has no memory). The observation normalisation
        is frozen here."""
        obs = np.asarray(observation, dtype=np.float32)
        if obs.shape[-1:] != (OBS_SIZE,):
            raise ValueError(f"observation must have {OBS_SIZE} entries in its last axis, got shape {obs.shape}")
        x = self.obs_norm(torch.as_tensor(obs.reshape(-1, OBS_SIZE)))
        action = self._action(x, deterministic).numpy().astype(np.float32)
        return action.reshape(*obs.shape[:-1], N_TAU), state

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        return self.predict(observation)[0]

    # ------------------------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the agent (weights, optimiser states, statistics, counters, settings) atomically;
        only tensors and plain data, so :meth:`load` reads it with ``weights_only=True``."""
        modules = {"actor": self.actor, "obs_norm": self.obs_norm}
        if self.critic is not None and self.target_critic is not None:
            modules |= {"critic": self.critic, "target_critic": self.target_critic}
        payload: dict[str, Any] = {f"{k}_state": m.state_dict() for k, m in modules.items()}
        payload |= {
            "algo": self.algo,
            "settings": _plain(dataclasses.asdict(self.settings)),
            "n_envs": self.n_envs,
            "env_kwargs": _plain(self.env_kwargs),
            "seed": self.seed,
            "obs_clip": self.obs_norm.clip,
            "log_std": self.log_std.detach().clone(),
            "actor_opt": self.actor_opt.state_dict(),
            "critic_opt": self.critic_opt.state_dict() if self.critic_opt is not None else None,
            "noise": self.noise.get_state(),
            "num_timesteps": self.num_timesteps,
            "updates": self.updates,
            "grad_mean": self.grad_mean.clone(),
            "grad_m2": self.grad_m2.clone(),
        }
        for name, value in payload.items():
            if torch.is_tensor(value) and value.is_floating_point() and not bool(torch.isfinite(value).all()):
                raise ValueError(f"refusing to save {path}: {name} holds non-finite values (training diverged)")
        return save_torch_file(path, DIFF_AGENT_KIND, payload)

    @classmethod
    def load(cls, path: str | Path, config: Any = None) -> DiffAgent:
        """Read an agent written by :meth:`save` (no code runs: ``torch.load(weights_only=True)``);
        a damaged, foreign or non-finite file is a :class:`sspinn.torch_files.ModelFileError`."""
        required = ("algo", "settings", "n_envs", "env_kwargs", "seed", "actor_state", "obs_norm_state", "log_std",
                    "num_timesteps", "updates")
        state = load_torch_file(path, [DIFF_AGENT_KIND], required, _HINT)
        check_finite_weights(path, {**state["actor_state"], "log_std": state["log_std"]}, _HINT)
        try:
            settings = config_from_mapping(DiffSettings, state["settings"], str(path), prefix="settings")
            agent = cls(state["algo"], settings, state["n_envs"], state["env_kwargs"], state["seed"],
                        obs_clip=float(state.get("obs_clip", 10.0)), config=config)
            agent.actor.load_state_dict(state["actor_state"])
            agent.obs_norm.load_state_dict(state["obs_norm_state"])
            with torch.no_grad():
                agent.log_std.copy_(state["log_std"])
            if agent.critic is not None and agent.target_critic is not None and agent.critic_opt is not None:
                agent.critic.load_state_dict(state["critic_state"])
                agent.target_critic.load_state_dict(state["target_critic_state"])
                agent.critic_opt.load_state_dict(state["critic_opt"])
            agent.actor_opt.load_state_dict(state["actor_opt"])
            agent.noise.set_state(state["noise"])
            agent.num_timesteps = int(state["num_timesteps"])
            agent.updates = int(state["updates"])
            agent.grad_mean = state.get("grad_mean", agent.grad_mean)
            agent.grad_m2 = state.get("grad_m2", agent.grad_m2)
        except (KeyError, RuntimeError, ValueError, TypeError, ConfigError) as exc:
            raise ModelFileError(f"{path}: not a usable {DIFF_AGENT_KIND} file ({str(exc).splitlines()[0]}); {_HINT}") from None
        return agent


def _plain(value: Any) -> Any:
    """Tuples as lists, mappings as dicts (plain data for the file)."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value

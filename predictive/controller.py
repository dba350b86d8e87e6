"""One controller protocol for every method that drives the walking environment.

Gait trackers (a generated or optimised gait cycle + feedforward + LQR,
:class:`predictive.generator.closed_loop.GaitTracker`) and stable-baselines3 policies are used the
same way, through SB3's ``predict`` convention::

    action, state = controller.predict(observation, state=None, episode_start=None, deterministic=True)

* ``state`` is everything the controller remembers between steps (a gait tracker's phase; an
  LSTM's hidden state). It is returned and passed back in by the caller, never kept inside the
  controller, so one controller object can run any number of episodes, one after the other or
  side by side (a batch of observations (n, 22) with ``episode_start`` (n,)).
* ``state=None`` or ``episode_start`` True (a bool, or an array with one entry per environment)
  starts an episode: the memory of that environment is reset. The first call of an episode must
  pass one of them; the helpers below do.
* ``initial_state``: ``(q, u)`` to start episodes from (``env.reset(options={"initial_state":
  ...})``; a gait tracker's cycle at phase 0), or None to start from the environment's standing
  pose.

A new speed or body is one call on a :class:`ControllerSource` (``controller_for(speed=1.3,
body=...)``), not a script. :func:`run_controller_episode` runs one episode of any controller with reset
options and returns what happened; :func:`episode_policy` adapts a controller to the plain
``observation → action`` functions of :mod:`agents.rollout`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from sspinn.model.body import BodyParameters


@runtime_checkable
class Controller(Protocol):
    """A controller of the walking environment (see the module docstring).

    Attributes:
        initial_state: ``(q, u)`` (9 coordinates and speeds each, SI) to start episodes from, or
            None for the environment's standing start.
    """

    initial_state: tuple[np.ndarray, np.ndarray] | None

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        """(action, state): the action (6,) or (n, 6) for an observation (22,) or (n, 22), and the
        state to pass back at the next step (``state=None`` or ``episode_start`` True starts an
        episode)."""
        ...


@runtime_checkable
class ControllerSource(Protocol):
    """Something that makes controllers: a trained generator, the OCP, a set of agents."""

    def controller_for(self, speed: float, body: BodyParameters | None = None) -> Controller:
        """A controller for ``speed`` (m/s) and ``body`` (None: the source's default body)."""
        ...


def episode_starts(episode_start: Any, n_envs: int) -> np.ndarray:
    """``episode_start`` (None, a bool, or an array of n_envs bools) as a (n_envs,) bool array.

    Raises:
        ValueError: an array with another number of entries.
    """
    if episode_start is None:
        return np.zeros(n_envs, dtype=bool)
    starts = np.asarray(episode_start, dtype=bool).reshape(-1)
    if starts.size == 1:
        return np.full(n_envs, bool(starts[0]))
    if starts.size != n_envs:
        raise ValueError(f"episode_start has {starts.size} entries for {n_envs} observations")
    return starts


def start_options(controller: Controller, reset_options: dict[str, Any] | None = None) -> dict[str, Any] | None:
    """The ``env.reset`` options of an episode of ``controller``: its ``initial_state`` (when it
    has one) under ``reset_options`` (which win)."""
    options: dict[str, Any] = {}
    initial = getattr(controller, "initial_state", None)
    if initial is not None:
        options["initial_state"] = initial
    options.update(reset_options or {})
    return options or None


def episode_policy(controller: Controller) -> Callable[[np.ndarray], np.ndarray]:
    """A plain ``observation → action`` function for ONE episode: its first call starts the
    episode (``episode_start`` True), later calls pass the state on. Make a new one per episode."""
    memory: dict[str, Any] = {"state": None, "start": True}

    def policy(observation: np.ndarray) -> np.ndarray:
        action, memory["state"] = controller.predict(observation, memory["state"], episode_start=memory["start"])
        memory["start"] = False
        return action

    return policy


@dataclass
class Episode:
    """One episode of a controller.

    Attributes:
        seed: reset seed. steps: control steps taken (0.01 s each). fell: terminated (not truncated).
        distance_m: hip displacement, m. mean_speed_m_s: distance / duration.
        actions: (steps, 6) actions, and states: (steps + 1, 18) q and u from the reset on, when recorded.
    """

    seed: int
    steps: int
    fell: bool
    distance_m: float
    mean_speed_m_s: float
    actions: np.ndarray | None = field(default=None, repr=False)
    states: np.ndarray | None = field(default=None, repr=False)


def run_controller_episode(
    controller: Controller, env: Any, seed: int, reset_options: dict[str, Any] | None = None, record: bool = False
) -> Episode:
    """One episode of ``controller`` in ``env`` from ``env.reset(seed=seed, options=...)`` (the
    controller's start state and ``reset_options``, :func:`start_options`) until it ends."""
    obs, _ = env.reset(seed=seed, options=start_options(controller, reset_options))
    unwrapped = getattr(env, "unwrapped", env)
    state, start = None, True
    actions, states = [], [np.concatenate(unwrapped.state)] if record else []
    terminated = truncated = False
    steps, info = 0, {"distance": 0.0}
    while not (terminated or truncated):
        action, state = controller.predict(obs, state, episode_start=start)
        start = False
        obs, _, terminated, truncated, info = env.step(action)
        steps += 1
        if record:
            actions.append(np.asarray(action, dtype=np.float64))
            states.append(np.concatenate(unwrapped.state))
    distance = float(info["distance"])
    return Episode(
        seed=seed, steps=steps, fell=bool(terminated), distance_m=distance,
        mean_speed_m_s=distance / (steps * float(unwrapped.dt)) if steps else 0.0,
        actions=np.asarray(actions) if record else None, states=np.asarray(states) if record else None,
    )


__all__ = ["Controller", "ControllerSource", "Episode", "episode_policy", "episode_starts", "run_controller_episode", "start_options"]

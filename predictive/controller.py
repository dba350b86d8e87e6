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
options and returns what happened; :func:`agents.rollout.run_episode` drives any controller
through the same ``predict`` protocol.
"""

from __future__ import annotations

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


class LegLengthCalibrated:
    """A controller of ``source`` for a body whose leg length may differ from the announced one.

    At every episode start it compares the pelvis height of the first observation with that of
    its nominal controller's ``initial_state``: the environment keeps the feet of a given start
    state where they would be on the announced body (:class:`envs.sagittal_walker.SagittalWalkerEnv`),
    so on a body with legs r times as long the ratio is r. Beyond ``tolerance`` it uses, for that
    episode, ``source.controller_for(speed, the body scaled to r × its height)``, else the nominal
    controller. Why: a gait tracker planned for legs 5 % off falls within a second, one planned for
    the true legs walks (docs/predictive_simulation.md). The estimate reads one sample: initial-state
    noise on the pelvis height (±5 cm under 10× reset noise) is taken for a leg-length change beyond
    ``tolerance``. Made controllers are cached by ratio (0.001 steps); the per-episode choice is in
    the returned state (ratios, the inner controllers' states), as the protocol asks.
    """

    def __init__(self, source: ControllerSource, speed: float, body: BodyParameters, tolerance: float = 0.01) -> None:
        self.source, self.speed, self.body, self.tolerance = source, float(speed), body, float(tolerance)
        self.nominal = source.controller_for(self.speed, body)
        self.initial_state = self.nominal.initial_state
        self.info = dict(getattr(self.nominal, "info", {}))
        self._made: dict[float, Controller] = {1.0: self.nominal}

    def ratio(self, observation: np.ndarray) -> float:
        """The leg-length ratio read from an episode's first observation (1.0 within ``tolerance``)."""
        if self.initial_state is None:
            return 1.0
        r = float(observation[0]) / float(self.initial_state[0][1])
        return 1.0 if abs(r - 1.0) <= self.tolerance else round(r, 3)

    def controller(self, ratio: float) -> Controller:
        """The controller for legs ``ratio`` times the announced body's (made once)."""
        if ratio not in self._made:
            body = BodyParameters.from_anthropometry(self.body.height * ratio, self.body.mass)
            self._made[ratio] = self.source.controller_for(self.speed, body)
        return self._made[ratio]

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        obs = np.asarray(observation, dtype=np.float64)
        batch = np.atleast_2d(obs)
        n = len(batch)
        starts = np.ones(n, dtype=bool) if state is None else episode_starts(episode_start, n)
        ratios = np.ones(n) if state is None else np.array(state[0], dtype=np.float64).reshape(-1)
        inner = [None] * n if state is None else list(state[1])
        actions = np.empty((n, 6), dtype=np.float32)
        for e in range(n):
            if starts[e]:
                ratios[e], inner[e] = self.ratio(batch[e]), None
            action, inner[e] = self.controller(ratios[e]).predict(batch[e], inner[e], episode_start=bool(starts[e]),
                                                                  deterministic=deterministic)
            actions[e] = action
        return (actions if obs.ndim == 2 else actions[0]), (ratios, inner)


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


__all__ = [
    "Controller", "ControllerSource", "Episode", "LegLengthCalibrated", "episode_starts",
    "run_controller_episode", "start_options",
]

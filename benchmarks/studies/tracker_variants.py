"""Tracker variants measured and not kept: falls under 10× reset noise of one generator at one speed.

Each variant wraps the configured tracker (``--config``'s ``tracker``, with the start sample
``--start``) of ``controller_for(speed, body)``; the feedback law stays a_ff[i] + K_i·(z_target − z):

* ``configured``: the tracker as built.
* ``foot_placement:K``: Raibert-style foot placement. While a leg swings forward in the reference
  (its contact point > 5 mm up, hip flexing), its hip target is moved by K·(v̄ − v_ref) rad, v̄ the
  forward speed low-pass filtered over 0.2 s (m/s), v_ref the plan's speed; K in rad per m/s.
* ``stance_events:W``: the phase runs by the clock and is re-synchronised only at stance events: when
  a foot's vertical load crosses 0.3 BW upward, the phase jumps to the sample at which it crosses
  it in the nominal closed loop (no noise), if that is within W samples.
* ``replan:DROP:STEP:HOLD``: when the forward speed low-pass filtered over 0.5 s is DROP m/s below
  the target (after the first 0.5 s), the controller switches to the generator's gait at that speed
  (0.1 m/s grid, at least 1 m/s; made once and kept), and moves back towards the target by STEP m/s
  after every HOLD s in which it holds the planned speed within 0.3 m/s.
* ``phase_metric:NAMES``: the state-based phase ignores the named states (``forward_speed``,
  ``vertical``: height and vertical speed) in its distance.

The wrappers keep their memory in the returned state (the controller protocol); one environment
at a time (no batches).

Usage: ``python -m benchmarks.studies.tracker_variants --generator runs/generator_s0/generator.pt
[--speed 3.5] [--seeds 200-239] [--start cycle_start] [--config configs/predictive/robustness.yaml]
configured foot_placement:0.1 stance_events:4 replan:0.8:0.5:1.0 phase_metric:forward_speed``.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import sys
from pathlib import Path
from typing import Any

import numpy as np

LOAD_BW = 0.3  # stance-event threshold on a foot's vertical load (BW)


class FootPlacement:
    """The tracker with Raibert-style swing-hip targets (module docstring)."""

    def __init__(self, tracker: Any, body: Any, gain: float, tau_s: float = 0.2) -> None:
        from sspinn.model.drawing import stick_points

        ref = tracker.reference
        points = stick_points(ref.q, body)
        high = np.stack([points["contact_r"][:, 1], points["contact_l"][:, 1]], axis=1) > 0.005
        self.swing = high & (ref.u[:, [3, 6]] > 0)  # (N, 2): leg in the air, hip flexing
        self.tracker, self.gain, self.alpha = tracker, gain, ref.dt / tau_s
        self.initial_state = tracker.initial_state

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True) -> tuple[np.ndarray, Any]:
        t, ref = self.tracker, self.tracker.reference
        z = np.asarray(observation, float)[:17]
        fresh = state is None or bool(episode_start)
        i = t.phase_of(z, None if fresh else state[0])
        v = ref.speed if fresh else state[1]
        v = (1 - self.alpha) * v + self.alpha * float(observation[8])
        target = ref.z[i].copy()
        for leg in range(2):
            if self.swing[i, leg]:
                target[2 + 3 * leg] += self.gain * (v - ref.speed)
        return np.clip(ref.action[i] + t.gains[i] @ (target - z), -1, 1).astype(np.float32), (i, v)


def nominal_events(tracker: Any, env_nominal: Any, steps: int = 300) -> list[list[int]]:
    """Per foot, the phases (samples) at which its vertical load crosses ``LOAD_BW`` upward in the
    tracker's closed loop without noise (after the first second)."""
    from predictive.controller import start_options

    obs, _ = env_nominal.reset(seed=0, options=start_options(tracker, {}))
    state, previous, events = None, obs[[18, 20]].copy(), [set(), set()]
    for k in range(steps):
        action, state = tracker.predict(obs, state, episode_start=k == 0)
        obs, *_ = env_nominal.step(action)
        for foot, load in enumerate(obs[[18, 20]]):
            if load > LOAD_BW >= previous[foot] and k >= 100:
                events[foot].add((int(state[0]) + 1) % tracker.reference.n)
        previous = obs[[18, 20]].copy()
    return [sorted(e) for e in events]


class StanceEvents:
    """The tracker on a clock phase re-synchronised at stance events (module docstring)."""

    def __init__(self, tracker: Any, events: list[list[int]], window: int) -> None:
        self.tracker, self.events, self.window = tracker, events, window
        self.initial_state = tracker.initial_state

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True) -> tuple[np.ndarray, Any]:
        t, ref, n = self.tracker, self.tracker.reference, self.tracker.reference.n
        obs = np.asarray(observation, float)
        z, loads = obs[:17], obs[[18, 20]]
        if state is None or bool(episode_start):
            i = t.phase_of(z, None)
        else:
            i = (state[0] + 1) % n
            for foot in range(2):
                if loads[foot] > LOAD_BW >= state[1][foot] and self.events[foot]:
                    offsets = [(e - i + n // 2) % n - n // 2 for e in self.events[foot]]
                    j = int(np.argmin(np.abs(offsets)))
                    if abs(offsets[j]) <= self.window:
                        i = self.events[foot][j]
        return np.clip(ref.action[i] + t.gains[i] @ (ref.z[i] - z), -1, 1).astype(np.float32), (i, loads.copy())


class Replan:
    """The generator's gait at the body's own speed after a large speed loss (module docstring)."""

    def __init__(self, source: Any, speed: float, body: Any, drop: float, step: float, hold_s: float) -> None:
        self.source, self.speed, self.body = source, speed, body
        self.drop, self.step, self.hold_steps = drop, step, int(round(hold_s * 100))
        self.made: dict[float, Any] = {}
        self.initial_state = self.tracker(speed).initial_state
        self.alpha = 0.01 / 0.5

    def tracker(self, speed: float) -> Any:
        speed = round(speed, 1)
        if speed not in self.made:
            self.made[speed] = self.source.controller_for(speed, self.body)
        return self.made[speed]

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True) -> tuple[np.ndarray, Any]:
        if state is None or bool(episode_start):
            plan, inner, v, since, k = self.speed, None, self.speed, 0, 0
        else:
            plan, inner, v, since, k = state
        v = (1 - self.alpha) * v + self.alpha * float(observation[8])
        since, k = since + 1, k + 1
        new = None
        if plan == self.speed and k > 50 and since > 50 and v < self.speed - self.drop:
            new = max(round(v, 1), 1.0)
        elif plan < self.speed and since > self.hold_steps and abs(v - plan) < 0.3:
            new = min(plan + self.step, self.speed)
        restart = inner is None
        if new is not None and round(new, 1) != round(plan, 1):
            plan, since, restart = new, 0, True
        action, inner = self.tracker(plan).predict(observation, inner, episode_start=restart)
        return action, (plan, inner, v, since, k)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generator", type=Path, required=True)
    parser.add_argument("--speed", type=float, default=3.5, help="m/s")
    parser.add_argument("--seeds", default="200-239", help="reset seeds, first-last")
    parser.add_argument("--start", default="cycle_start", help="tracker.start of the wrapped tracker")
    parser.add_argument("--config", type=Path, default=Path("configs/predictive/robustness.yaml"))
    parser.add_argument("variants", nargs="+")
    args = parser.parse_args(argv)

    from predictive.controller import run_controller_episode
    from predictive.experiments.robustness import RobustnessConfig, evaluation_env
    from predictive.generator.controllers import GeneratorControllers
    from sspinn.model.body import BodyParameters

    config = RobustnessConfig.from_yaml(args.config, [f"generators=[{args.generator}]"])
    body = BodyParameters.from_anthropometry(config.height, config.mass)
    source = GeneratorControllers.from_file(args.generator, tracker=dataclasses.replace(config.tracker, start=args.start))
    tracker = source.controller_for(args.speed, body)
    env = evaluation_env(args.speed, body, config.env)
    lo, _, hi = args.seeds.partition("-")
    seeds = list(range(int(lo), int(hi or lo) + 1))
    print(f"{args.generator} at {args.speed} m/s, start sample {tracker.start} of {tracker.reference.n}, "
          f"reset seeds {seeds[0]}–{seeds[-1]}, environment overrides {config.env}")
    for variant in args.variants:
        name, *params = variant.split(":")
        if name == "configured":
            controller: Any = tracker
        elif name == "foot_placement":
            controller = FootPlacement(tracker, body, float(params[0]))
        elif name == "stance_events":
            events = nominal_events(tracker, evaluation_env(args.speed, body, {"reset_noise_scale": 0.0}))
            controller = StanceEvents(tracker, events, int(params[0]))
        elif name == "replan":
            controller = Replan(source, args.speed, body, *map(float, params))
        elif name == "phase_metric":
            controller = copy.copy(tracker)
            controller.metric = tracker.metric.copy()
            for part in params[0].split(","):
                controller.metric[{"forward_speed": [8], "vertical": [0, 9]}[part]] = 0.0
        else:
            parser.error(f"unknown variant {variant!r}")
        episodes = [run_controller_episode(controller, env, seed) for seed in seeds]
        falls = [(e.seed, round(e.steps / 100, 2)) for e in episodes if e.fell]
        print(f"{variant:<28} falls {len(falls)}/{len(seeds)}  (seed, fall time s): {falls}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

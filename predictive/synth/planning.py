"""Stride plans of a synthetic recording: speed program, stride-to-stride variability, speed changes.

A recording runs through its program's speeds (equal shares of its duration); :func:`plan_strides`
turns that into one :class:`~predictive.ocp.stride_nlp.StridePlan` per stride. Variability
(:class:`~predictive.synth.config.Variability`): each stride's speed is the program's target
×(1 + 2 % N(0, 1)), its duration the reference duration at that speed ×(1 + 2 % N(0, 1))
(stride-time CVs of healthy adults are of the order of 2 %; Hausdorff et al. 1995, J Appl
Physiol 78:349–358), and its per-joint effort weights are log-normal (σ = 0.2); the normal draws
are clipped. Speed changes: the target moves to the program's next speed by at most 0.25 m/s per
stride. The plans are deterministic given the random generator (a stream of the dataset seed).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from predictive.ocp.stride_nlp import StridePlan
from predictive.synth.config import Variability
from predictive.synth.periodic_reference import PeriodicReference
from sspinn.model.conventions import N_TAU


def plan_strides(
    speeds: Sequence[float],
    duration_s: float,
    reference: PeriodicReference,
    variability: Variability,
    h: float,
    rng: np.random.Generator,
) -> list[StridePlan]:
    """Strides covering at least ``duration_s`` seconds: the target speed runs through ``speeds``
    (equal shares of the duration, ramps of at most ``max_speed_change`` per stride), with the
    per-stride variability of ``variability`` (see the module docstring)."""
    var = variability
    share = duration_s / len(speeds)
    plans: list[StridePlan] = []
    t, v_sched = 0.0, float(speeds[0])
    while t < duration_s - 1e-9:
        target = float(speeds[min(int(t / share), len(speeds) - 1)])
        v_sched = float(np.clip(target, v_sched - var.max_speed_change, v_sched + var.max_speed_change))
        z = np.clip(rng.standard_normal(2 + N_TAU), -var.clip, var.clip)
        v = v_sched * (1 + var.speed_cv * z[0])
        n = int(round(reference.nominal_duration(v) * (1 + var.duration_cv * z[1]) / h))
        weights = tuple(float(w) for w in np.exp(var.effort_log_sd * z[2:]))
        plans.append(StridePlan(speed=float(v), n_nodes=n, effort_weights=weights))
        t += n * h
    return plans

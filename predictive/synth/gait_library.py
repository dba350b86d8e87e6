"""Periodic gaits of a synthetic dataset: nominal templates, each subject's own, their fallbacks.

A recording's stride chain needs periodic gaits of the subject's true body at the program's
speeds as initial guesses and terminal targets (:mod:`predictive.synth.periodic_reference`).
:func:`periodic_library` solves them with :func:`predictive.solve_predictive` (symmetric half
cycle) at each program speed, on the exact 100 Hz grid (stride duration
:func:`predictive.typical_stride_duration` scaled by √(leg length / 0.93 m), rounded to 0.02 s:
:func:`periodic_duration`), warm-started from the same speed's solution of a nominal 1.75 m,
70 kg body (:func:`template_library`, solved once by continuation from 1.3 and 3.5 m/s), which
keeps every subject in the same gait family (a generic guess at 0.9 m/s converges to a hopping
gait). Periodic gaits have a fallback ladder of their own (:data:`PERIODIC_FALLBACKS`); a
subject whose own gait fails on every rung uses the template. All are cached
(:class:`~predictive.synth.cache.SynthCache`) by body, settings and the guess's key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, Final

from predictive.ocp.collocation import OCPError, solve_predictive
from predictive.ocp.generic_gait import typical_stride_duration
from predictive.ocp.settings import WALK_RUN_SPEED
from predictive.ocp.solution import GaitSolution
from predictive.ocp.stride_nlp import WARM_START_IPOPT, StrideSettings
from predictive.synth.cache import CODE_VERSION, SynthCache, stable_hash
from sspinn.model.body import BodyParameters

#: Speeds at or above this are solved as running (template continuation from 3.5 m/s), m/s.
RUN_SPEED: Final = WALK_RUN_SPEED
#: Template speeds solved from the generic guess; the others by continuation from them, m/s.
ANCHORS: Final[tuple[float, float]] = (1.3, 3.5)
#: Standing hip height (femur + tibia + ankle height) of the 1.75 m Winter body, m (stride-duration scaling).
REFERENCE_LEG_LENGTH: Final = 0.9275


def periodic_duration(speed: float, body: BodyParameters, h: float) -> float:
    """Stride duration of the periodic reference at ``speed`` (m/s) for ``body``, s: the typical
    duration × √(standing hip height / 0.9275 m), rounded to a multiple of 2h (whole half cycles)."""
    leg = body.standing_hip_height
    T = typical_stride_duration(speed) * math.sqrt(leg / REFERENCE_LEG_LENGTH)
    return round(T / (2 * h)) * 2 * h


def _solve_periodic(
    speed: float,
    body: BodyParameters,
    stride: StrideSettings,
    guess: GaitSolution | None,
    ipopt_options: Mapping[str, Any] | None = None,
) -> GaitSolution:
    """The symmetric half-cycle gait of ``body`` at ``speed`` (m/s) on the stride grid
    (:func:`periodic_duration`, ``stride.h``) with the stride problem's model
    (:meth:`~predictive.ocp.stride_nlp.StrideSettings.ocp_settings`)."""
    T = periodic_duration(speed, body, stride.h)
    n_half = round(T / (2 * stride.h))
    return solve_predictive(
        speed, body, n_nodes=n_half, duration=T, guess=guess, ipopt_options=ipopt_options, **stride.model_settings()
    )


def _periodic_key(speed: float, body: BodyParameters, stride: StrideSettings, guess_key: str | None) -> str:
    T = periodic_duration(speed, body, stride.h)
    settings = stride.ocp_settings(speed, round(T / (2 * stride.h)), T).to_dict()
    return stable_hash({"code": CODE_VERSION, "body": body.vector(), "ocp": settings, "guess": guess_key})


def _continuation_order(speeds: Sequence[float]) -> list[tuple[float, float | None]]:
    """(speed, speed of its guess or None for the generic guess): each gait family (walking
    below RUN_SPEED, running above) starts at its anchor and proceeds to the nearest solved speed."""
    order: list[tuple[float, float | None]] = []
    for anchor, family in (
        (ANCHORS[0], [v for v in speeds if v < RUN_SPEED]),
        (ANCHORS[1], [v for v in speeds if v >= RUN_SPEED]),
    ):
        if not family:
            continue
        solved = [anchor]
        order.append((anchor, None))
        for v in sorted(set(family) - {anchor}, key=lambda x: (abs(x - anchor), x)):
            nearest = min(solved, key=lambda s: (abs(s - v), s))
            order.append((v, nearest))
            solved.append(v)
    return order


def template_families(speeds: Sequence[float]) -> list[list[float]]:
    """``speeds`` split into gait families (walking below :data:`RUN_SPEED`, running at or above),
    the empty ones left out. :func:`template_library` solves each family by a continuation of its
    own, so the families can be solved apart, in parallel, to the same solutions and cache keys."""
    families = ([v for v in speeds if v < RUN_SPEED], [v for v in speeds if v >= RUN_SPEED])
    return [family for family in families if family]


def template_library(
    speeds: Sequence[float], stride: StrideSettings, cache: SynthCache
) -> dict[float, tuple[GaitSolution, str]]:
    """Periodic gaits of the nominal 1.75 m, 70 kg body at ``speeds`` (plus the anchors), solved by
    continuation (see :func:`_continuation_order`); returns speed → (solution, cache key)."""
    body = BodyParameters.from_anthropometry(1.75, 70.0)
    out: dict[float, tuple[GaitSolution, str]] = {}
    for speed, guess_speed in _continuation_order(speeds):
        guess, guess_key = (None, None) if guess_speed is None else out[guess_speed]
        key = _periodic_key(speed, body, stride, guess_key)
        try:
            sol = cache.periodic(key, lambda s=speed, g=guess: _solve_periodic_ladder(s, body, stride, g))
        except OCPError as exc:
            if guess_speed is None:
                raise OCPError(exc.status, f"template gait at {speed} m/s (an anchor): {exc}") from exc
            # continuation in two smaller steps: through the midpoint of the speeds
            mid = round(0.5 * (speed + guess_speed), 6)
            mid_key = _periodic_key(mid, body, stride, guess_key)
            try:
                mid_sol = cache.periodic(mid_key, lambda g=guess, m=mid: _solve_periodic_ladder(m, body, stride, g))
                key = _periodic_key(speed, body, stride, mid_key)
                sol = cache.periodic(key, lambda s=speed, g=mid_sol: _solve_periodic_ladder(s, body, stride, g))
            except OCPError as exc2:
                raise OCPError(
                    exc2.status,
                    f"template gait at {speed} m/s could not be reached by continuation from {guess_speed} m/s, "
                    f"directly or through {mid} m/s ({exc2}); remove {speed} m/s from the programs",
                ) from exc2
        out[speed] = (sol, key)
    return out


#: Fallbacks of a periodic gait, in order: (use the continuation guess, IPOPT options). A failed
#: warm start is retried with IPOPT's defaults, then from the data-free guess, which is a
#: multi-start (:data:`predictive.ocp.collocation.DEFAULT_STARTS`: other amplitudes, a monotone barrier).
PERIODIC_FALLBACKS: Final[tuple[tuple[bool, Mapping[str, Any] | None], ...]] = (
    (True, WARM_START_IPOPT),
    (True, None),
    (False, None),
)


def _solve_periodic_ladder(
    speed: float, body: BodyParameters, stride: StrideSettings, guess: GaitSolution | None, warm_start: bool = False
) -> GaitSolution:
    """:func:`_solve_periodic` down :data:`PERIODIC_FALLBACKS` (rungs with the guess are skipped
    when there is none, the warm-start rung unless ``warm_start``: the guess is the same speed's
    solution of a similar body); raises the last :class:`OCPError` if every rung fails."""
    error: OCPError | None = None
    for use_guess, options in PERIODIC_FALLBACKS:
        if (use_guess and guess is None) or (options is WARM_START_IPOPT and not warm_start):
            continue
        try:
            return _solve_periodic(speed, body, stride, guess if use_guess else None, options)
        except OCPError as exc:
            error = exc
    assert error is not None
    raise error


def periodic_library(
    body: BodyParameters,
    speeds: Sequence[float],
    stride: StrideSettings,
    cache: SynthCache,
    templates: Mapping[float, tuple[GaitSolution, str]],
    events: list[dict[str, str]] | None = None,
    name: str = "",
) -> dict[float, tuple[GaitSolution, str]]:
    """Periodic gaits of ``body`` at ``speeds`` (m/s), each warm-started from the template at the
    same speed with IPOPT's warm-start options (:data:`~predictive.ocp.stride_nlp.WARM_START_IPOPT`:
    faster, and it stays in the template's gait), falling back down :data:`PERIODIC_FALLBACKS`.
    If every rung fails, the nominal body's template serves as that speed's reference (it is only
    the chain's initial guess and terminal target: the labels still come from stride OCPs of the
    true body) and an event ``periodic_from_template`` naming ``name`` is appended to ``events``.
    Returns speed → (solution, cache key)."""
    out: dict[float, tuple[GaitSolution, str]] = {}
    for speed in speeds:
        guess, guess_key = templates[speed]
        key = _periodic_key(speed, body, stride, guess_key)
        try:
            solution = cache.periodic(key, lambda s=speed, g=guess: _solve_periodic_ladder(s, body, stride, g, True))
        except OCPError as exc:
            if events is not None:
                detail = f"periodic gait at {speed} m/s failed on every rung ({exc}); the nominal template is the reference"
                events.append({"recording": name, "event": "periodic_from_template", "detail": detail})
            out[speed] = (guess, guess_key)
            continue
        out[speed] = (solution, key)
    return out

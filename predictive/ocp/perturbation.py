"""Floating-point-path perturbations of every IPOPT solve, for robustness checks.

IPOPT from one initial guess is one sample of a distribution: the same code reaches different
local optima on machines whose BLAS, vector units or thread counts round differently (measured:
other local optima and one infeasible stride on an AVX-512 AMD EPYC than on an AVX2 one). ``scripts/check_robustness.py`` simulates other machines by running the
OCP tests and the default synthetic dataset under perturbations that change the floating-point
path without changing the problem. They are read from environment variables, so that they reach
every solve in subprocesses (pytest, spawned generator workers) without new arguments:

``SSPINN_OCP_JITTER``
    relative noise added to every initial guess: ``x0 ← x0·(1 + ε·z) + ε·z'`` with z, z' ~ N(0, 1)
    (the additive part moves exact zeros too), e.g. ``1e-9``. Default 0 (off).
``SSPINN_OCP_SEED``
    seed of that noise (default 0). Each solve draws from ``(seed, hash of its guess)``: the same
    guess always gets the same noise, so perturbed runs stay deterministic.
``SSPINN_IPOPT_OPTIONS``
    a JSON object of extra IPOPT options merged into every solver, e.g.
    ``{"mumps_pivtol": 1e-4}`` (MUMPS pivoting threshold) or
    ``{"mumps_permuting_scaling": 0}``.

With none of them set, :func:`perturb_guess` returns its argument unchanged and
:func:`extra_ipopt_options` an empty mapping: the library behaves exactly as without this module.
"""

from __future__ import annotations

import hashlib
import json
import os
from typing import Any, Final

import numpy as np

#: The environment variables read here.
JITTER_VAR: Final = "SSPINN_OCP_JITTER"
SEED_VAR: Final = "SSPINN_OCP_SEED"
IPOPT_VAR: Final = "SSPINN_IPOPT_OPTIONS"


def jitter() -> float:
    """The relative guess noise ε of ``SSPINN_OCP_JITTER`` (0 when unset)."""
    raw = os.environ.get(JITTER_VAR, "").strip()
    if not raw:
        return 0.0
    try:
        value = float(raw)
    except ValueError:
        raise ValueError(f"{JITTER_VAR}={raw!r}: expected a number such as 1e-9") from None
    if not (np.isfinite(value) and 0.0 <= value < 1e-2):
        raise ValueError(f"{JITTER_VAR}={raw!r}: expected a relative noise in [0, 1e-2)")
    return value


def perturb_guess(x0: np.ndarray, lbx: np.ndarray | None = None, ubx: np.ndarray | None = None) -> np.ndarray:
    """``x0`` with the configured relative noise (clipped to the bounds), or ``x0`` itself."""
    eps = jitter()
    if eps == 0.0:
        return x0
    seed = int(os.environ.get(SEED_VAR, "0") or 0)
    x = np.asarray(x0, dtype=float)
    # seeded by the guess itself: the same solve from the same guess gets the same noise, so a
    # perturbed run is as deterministic as an unperturbed one (caches and re-solves agree)
    digest = hashlib.sha256(np.ascontiguousarray(x).tobytes()).digest()
    rng = np.random.default_rng([seed, int.from_bytes(digest[:8], "little")])
    out = x * (1.0 + eps * rng.standard_normal(x.shape)) + eps * rng.standard_normal(x.shape)
    if lbx is not None and ubx is not None:
        out = np.clip(out, lbx, ubx)
    return out


def extra_ipopt_options() -> dict[str, Any]:
    """The IPOPT options of ``SSPINN_IPOPT_OPTIONS`` (empty when unset)."""
    raw = os.environ.get(IPOPT_VAR, "").strip()
    if not raw:
        return {}
    try:
        options = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{IPOPT_VAR}: not a JSON object ({exc})") from None
    if not isinstance(options, dict):
        raise ValueError(f"{IPOPT_VAR}: expected a JSON object of IPOPT options, got {raw!r}")
    return options

"""Array namespaces (``ops``) on which the generated model code runs: NumPy, torch, CasADi.

The generated functions in ``sspinn/model/_generated/model_expr.py`` need only a handful of
primitives: elementwise ``sin, cos, tanh, exp, sqrt, softplus``, ``take`` (split the last axis
into components) and ``pack`` (stack components into the output shape, broadcasting batch
dimensions). Each namespace below provides exactly these; :func:`ops_for` picks one from the
type of an input. torch and CasADi are imported lazily so the NumPy path needs neither.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np


class NumpyOps:
    """NumPy arrays with any leading batch dimensions; float64."""

    name = "numpy"
    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    tanh = staticmethod(np.tanh)
    exp = staticmethod(np.exp)
    sqrt = staticmethod(np.sqrt)

    @staticmethod
    def softplus(x):
        return np.logaddexp(0.0, x)

    @staticmethod
    def take(x, idx: Sequence[int]) -> list:
        x = np.asarray(x, dtype=np.float64)
        return [x[..., i] for i in idx]

    @staticmethod
    def pack(elems: list, shape: tuple[int, ...]):
        arrays = np.broadcast_arrays(*(np.asarray(e, dtype=np.float64) for e in elems))
        out = np.stack(arrays, axis=-1)
        return out.reshape(out.shape[:-1] + tuple(shape))


class TorchOps:
    """torch tensors with any leading batch dimensions; dtype and device follow the inputs;
    differentiable."""

    name = "torch"

    def __init__(self) -> None:
        import torch
        import torch.nn.functional as F

        self._torch = torch
        self.sin, self.cos, self.tanh, self.exp, self.sqrt = torch.sin, torch.cos, torch.tanh, torch.exp, torch.sqrt
        self.softplus = F.softplus

    @staticmethod
    def take(x, idx: Sequence[int]) -> list:
        parts = x.unbind(-1)
        return [parts[i] for i in idx]

    def pack(self, elems: list, shape: tuple[int, ...]):
        torch = self._torch
        ref = next(e for e in elems if isinstance(e, torch.Tensor))
        tensors = [e if isinstance(e, torch.Tensor) else torch.full((), float(e), dtype=ref.dtype, device=ref.device) for e in elems]
        out = torch.stack(torch.broadcast_tensors(*tensors), dim=-1)
        return out.reshape(*out.shape[:-1], *shape)


class CasadiOps:
    """CasADi SX/MX/DM column vectors (one state, no batch dimension)."""

    name = "casadi"

    def __init__(self) -> None:
        import casadi as ca

        self._ca = ca
        self.sin, self.cos, self.tanh, self.exp, self.sqrt = ca.sin, ca.cos, ca.tanh, ca.exp, ca.sqrt

    def softplus(self, x):
        ca = self._ca
        return ca.fmax(x, 0) + ca.log1p(ca.exp(-ca.fabs(x)))

    @staticmethod
    def take(x, idx: Sequence[int]) -> list:
        return [x[i] for i in idx]

    def pack(self, elems: list, shape: tuple[int, ...]):
        ca = self._ca
        v = ca.vertcat(*elems)
        if len(shape) == 1:
            return v
        rows, cols = shape
        return ca.reshape(v, cols, rows).T  # elems are row-major, CasADi reshapes column-major


_NAMESPACES: dict[str, Any] = {}
_KINDS = {"numpy": NumpyOps, "torch": TorchOps, "casadi": CasadiOps}


def _namespace(kind: str) -> Any:
    """One instance per kind, made on first use (a plain dict rather than ``functools.cache``,
    which ``torch.compile`` traces through with a warning)."""
    if kind not in _NAMESPACES:
        _NAMESPACES[kind] = _KINDS[kind]()
    return _NAMESPACES[kind]


def backend_name(x: Any) -> str:
    """'torch' for tensors, 'casadi' for SX/MX/DM, else 'numpy'."""
    mod = type(x).__module__
    for kind in ("torch", "casadi"):
        if mod.startswith(kind):
            return kind
    return "numpy"


def ops_for(x: Any) -> Any:
    """The namespace for an input (see :func:`backend_name`)."""
    return _namespace(backend_name(x))

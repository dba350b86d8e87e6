"""Matplotlib figures of the sagittal model: stick figures and time series."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from sspinn.model import kinematics
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import SIDES
from sspinn.run_folder import atomic_path

_CHAIN = ("hip", "knee_{s}", "ankle_{s}", "heel_{s}", "toe_{s}", "ankle_{s}")
_COLORS = {"r": "tab:red", "l": "tab:blue"}


def stick_points(q: np.ndarray, body: BodyParameters) -> dict[str, np.ndarray]:
    """Global (x, y) of every drawn point for poses q (..., 9): name → (..., 2), plus the
    shoulder ('head' end of the HAT segment)."""
    zeros = np.zeros_like(q)
    pk = kinematics.point_kinematics(q, zeros, zeros, np.zeros(q.shape[:-1] + (2,)), body)
    pts = {name: pk[..., kinematics.point_index(name), :2] for name in kinematics.POINTS}
    tilt = q[..., 2]
    pts["shoulder"] = pts["hip"] + body.pelvis.length * np.stack([-np.sin(tilt), np.cos(tilt)], -1)
    return pts


def draw_stick_figure(ax: Any, q: np.ndarray, body: BodyParameters, alpha: float = 1.0, grf: np.ndarray | None = None) -> None:
    """Draw one pose (9,) on a matplotlib Axes (right leg red, left leg blue); optional GRF
    arrows (4,) in N, drawn at the contact points at 1 m per 1000 N."""
    pts = stick_points(q, body)
    hat = np.stack([pts["hip"], pts["shoulder"]])
    ax.plot(hat[:, 0], hat[:, 1], color="k", lw=3, alpha=alpha, solid_capstyle="round")
    for s in SIDES:
        chain = np.stack([pts[name.format(s=s)] for name in _CHAIN])
        ax.plot(chain[:, 0], chain[:, 1], color=_COLORS[s], lw=2, alpha=alpha, marker="o", ms=2)
        if grf is not None:
            k = 0 if s == "r" else 2
            c = pts[f"contact_{s}"]
            if grf[k + 1] > 1.0:
                ax.arrow(c[0], c[1], grf[k] / 1000, grf[k + 1] / 1000, color=_COLORS[s], width=0.004, alpha=alpha)


def save_figure(fig: Any, path: str | Path, dpi: int = 100) -> Path:
    """Lay out ``fig``, write it to ``path`` atomically (parent folders created; the format from
    the suffix, PNG without one) and close it; returns the path."""
    import matplotlib.pyplot as plt

    path = Path(path)
    try:
        fig.tight_layout()
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".").lower() or "png")
    finally:
        plt.close(fig)
    return path

"""The SSPINNpose network: IMU signals (+ body, placement and contact constants) → gait dynamics.

Architecture (Gambietz et al., SSPINNpose): an LSTM (2 layers, hidden 512, dropout 0.4;
unidirectional for real time, optionally bidirectional offline), a dense layer of 128 units and
a linear layer with 46 outputs per time step:

==========  =====  ====================================================================
block       size   content (decoded by :func:`decode`; SI units, conventions module)
==========  =====  ====================================================================
q           8      all coordinates but pelvis_tx (the horizontal root position is the
                   integral of the estimated horizontal root velocity)
u           9      generalized speeds
qdd         9      generalized accelerations
tau         6      joint torques
contact     14     per foot (r, l): ankle [x − pelvis_tx, y, vx, vy, ax, ay] estimated
                   separately from the kinematic chain, and the friction factor μ̂
==========  =====  ====================================================================

Raw outputs are dimensionless; :func:`decode` scales them by body size (height, body weight)
and typical gait magnitudes so that a unit output is a plausible amount of each quantity.
Inputs (:func:`input_features`: the IMU signals, then height, mass and IMU placement) are
normalised with per-channel statistics stored in the model (buffers), so a saved model
(:mod:`sspinn.model_io`) carries everything it needs.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn

from sspinn.conventions import N_Q, N_TAU, SEGMENTS

N_OUTPUTS = (N_Q - 1) + N_Q + N_Q + N_TAU + 14
assert N_OUTPUTS == 46


@dataclass(frozen=True)
class NetworkConfig:
    """LSTM size. Defaults are the paper's; ``configs/sspinn/demo.yaml`` uses a CPU-sized one."""

    hidden: int = 512
    layers: int = 2
    dropout: float = 0.4
    dense: int = 128
    bidirectional: bool = False

    def __post_init__(self) -> None:
        if self.hidden < 1 or self.layers < 1 or self.dense < 1:
            raise ValueError(f"network sizes must be positive: {self}")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"dropout must be in [0, 1), got {self.dropout}")


@dataclass
class Estimate:
    """Decoded network outputs, each (..., T, n) in SI units (see the module docstring)."""

    q: torch.Tensor  # (..., T, 9), pelvis_tx integrated from u
    u: torch.Tensor  # (..., T, 9)
    qdd: torch.Tensor  # (..., T, 9)
    tau: torch.Tensor  # (..., T, 6)
    ankle: torch.Tensor  # (..., T, 2, 6): [x − pelvis_tx, y, vx, vy, ax, ay] per foot (r, l)
    mu_hat: torch.Tensor  # (..., T, 2)

    def ankle_global(self) -> torch.Tensor:
        """(..., T, 8): [x, y, vx, vy] per foot with x made global by adding pelvis_tx."""
        a = self.ankle[..., :4].clone()
        a[..., 0] = a[..., 0] + self.q[..., :1]
        return a.flatten(-2)


def input_features(imu: np.ndarray, height: float, mass: float, placement: np.ndarray, segments: tuple[str, ...]) -> np.ndarray:
    """(T, n_imu·3 + 2 + n_imu·3): IMU signals, then height, mass and the placement of the used
    IMUs, repeated over time (the paper's θ_b and θ_IMU inputs)."""
    idx = np.concatenate([np.arange(3) + 3 * SEGMENTS.index(s) for s in segments])
    consts = np.concatenate([[height, mass], placement[idx]])
    T = imu.shape[0]
    return np.concatenate([imu.reshape(T, -1), np.broadcast_to(consts, (T, consts.size))], axis=1)


#: Normalisation std of an input feature that was constant in training (see
#: :meth:`SSPINNposeNet.set_normalisation`).
UNSEEN_STD: float = 1e9


def feature_std_floor(segments: tuple[str, ...]) -> torch.Tensor:
    """Smallest normalisation std of each :func:`input_features` column: 0.1 for the IMU
    channels (m/s², rad/s), 0.05 m for the height, 5 kg for the mass, and 0.02 m / 0.05 rad for
    the placement positions / angles."""
    n = len(segments)
    return torch.tensor([0.1] * 3 * n + [0.05, 5.0] + [0.02, 0.02, 0.05] * n, dtype=torch.float32)


class SSPINNposeNet(nn.Module):
    """LSTM → dense(128) → 46 outputs per time step (see the module docstring).

    Args:
        n_inputs: features per time step (IMU channels + constants).
        config: network sizes.
    """

    def __init__(self, n_inputs: int, config: NetworkConfig = NetworkConfig()) -> None:
        super().__init__()
        self.config = config
        self.n_inputs = n_inputs
        self.lstm = nn.LSTM(
            n_inputs,
            config.hidden,
            num_layers=config.layers,
            dropout=config.dropout if config.layers > 1 else 0.0,
            batch_first=True,
            bidirectional=config.bidirectional,
        )
        width = config.hidden * (2 if config.bidirectional else 1)
        self.head = nn.Sequential(nn.Linear(width, config.dense), nn.ELU(), nn.Linear(config.dense, N_OUTPUTS))
        self.register_buffer("input_mean", torch.zeros(n_inputs))
        self.register_buffer("input_std", torch.ones(n_inputs))

    def set_normalisation(self, mean: torch.Tensor, std: torch.Tensor, floor: torch.Tensor | None = None) -> None:
        """Per-feature statistics of the training inputs, the std at least ``floor``
        (:func:`feature_std_floor`).

        A feature that did not vary in training at all (std ≤ 1e-6 × max(1, |mean|), e.g. the
        IMU placement when every training recording has the same) gets std :data:`UNSEEN_STD`:
        the network sees 0 for it whatever its value, since it cannot have learned what a change
        of it means. The floor keeps a feature that varied little in training (four synthetic
        subjects of 1.77 ± 0.01 m) from becoming an input of 13 σ on a 1.90 m subject, which
        saturated the LSTM on real data."""
        self.input_mean.copy_(mean)
        constant = std <= 1e-6 * mean.abs().clamp_min(1.0)
        floored = std if floor is None else torch.maximum(std, floor.to(std))
        self.input_std.copy_(torch.where(constant, torch.full_like(std, UNSEEN_STD), floored))

    def forward(
        self, x: torch.Tensor, state: tuple[torch.Tensor, torch.Tensor] | None = None
    ) -> tuple[torch.Tensor, tuple[torch.Tensor, torch.Tensor]]:
        """x (B, T, n_inputs) in physical units → raw outputs (B, T, 46) and the LSTM state."""
        if x.shape[-1] != self.n_inputs:
            raise ValueError(f"expected {self.n_inputs} input features, got {x.shape[-1]}")
        h, state = self.lstm((x - self.input_mean) / self.input_std, state)
        return self.head(h), state

    def hyperparameters(self) -> dict:
        return {"n_inputs": self.n_inputs, **asdict(self.config)}


#: Typical magnitudes of the generalized speeds (m/s, m/s, then rad/s) and accelerations
#: (m/s², m/s², then rad/s²) in gait: the output scales, also used to normalise losses.
TYPICAL_U: tuple[float, ...] = (1.5, 0.5) + (4.0,) * 7
TYPICAL_QDD: tuple[float, ...] = (10.0, 10.0) + (50.0,) * 7

#: Blocks of the 46 outputs (see the module docstring).
BLOCKS = {"q": slice(0, 8), "u": slice(8, 17), "qdd": slice(17, 26), "tau": slice(26, 32), "contact": slice(32, 46)}


def output_affine(height: float, mass: float, leg_length: float, gravity: float = 9.81) -> tuple[np.ndarray, np.ndarray]:
    """(scale, offset), each (46,): physical output = raw · scale + offset for one subject.

    Lengths scale with height, torques with m·g·h (10 %BW·BH ≈ 120 N·m at 1.75 m, 70 kg), rates
    and accelerations with typical gait magnitudes; pelvis_ty is offset by the standing hip
    height ``leg_length`` and the ankle heights by the standing ankle height (≈ 0.039·height).
    """
    torque = 0.1 * mass * gravity * height
    q = [0.05 * height] + [0.5] * 7
    u = list(TYPICAL_U)
    qdd = list(TYPICAL_QDD)
    ankle = [0.2 * height, 0.05 * height, 2.0, 1.0, 20.0, 20.0, 1.0]
    scale = np.array(q + u + qdd + [torque] * N_TAU + ankle + ankle)
    offset = np.zeros(N_OUTPUTS)
    offset[0] = leg_length
    offset[32 + 1] = offset[32 + 7 + 1] = 0.039 * height
    return scale, offset


def split_outputs(scaled, root_x):
    """Blocks of physical outputs (..., 46) (NumPy or torch) as a dict of q (with the given
    ``root_x`` as pelvis_tx), u, qdd, tau, ankle (..., 2, 6) and mu_hat (..., 2)."""
    cat = torch.cat if isinstance(scaled, torch.Tensor) else np.concatenate
    contact = scaled[..., BLOCKS["contact"]].reshape(*scaled.shape[:-1], 2, 7)
    return {
        "q": cat([root_x[..., None], scaled[..., BLOCKS["q"]]], -1),
        "u": scaled[..., BLOCKS["u"]],
        "qdd": scaled[..., BLOCKS["qdd"]],
        "tau": scaled[..., BLOCKS["tau"]],
        "ankle": contact[..., :6],
        "mu_hat": contact[..., 6],
    }


def decode(raw: torch.Tensor, scale: torch.Tensor, offset: torch.Tensor, dt: float) -> Estimate:
    """Raw outputs (B, T, 46) → :class:`Estimate`, with per-sequence ``scale``/``offset`` (B, 46)
    from :func:`output_affine`; pelvis_tx is the cumulative (trapezoidal) integral of the
    estimated horizontal root velocity, starting at 0 in each sequence."""
    scaled = raw * scale[:, None, :] + offset[:, None, :]
    vx = scaled[..., BLOCKS["u"].start]
    tx = torch.cat([torch.zeros_like(vx[:, :1]), torch.cumsum(0.5 * (vx[:, 1:] + vx[:, :-1]) * dt, dim=1)], dim=1)
    return Estimate(**split_outputs(scaled, tx))

"""The SSPINNpose network: IMU signals (+ body, placement and contact constants) → gait dynamics.

Architecture (Gambietz et al., SSPINNpose): an LSTM (2 layers, hidden 512, dropout 0.4;
unidirectional for real time, optionally bidirectional offline), a dense layer of 128 units and
a linear layer with 46 outputs per time step (36 with direct ground reaction forces):

==========  =====  ====================================================================
block       size   content (decoded by :func:`decode`; SI units, conventions module)
==========  =====  ====================================================================
q           8      all coordinates but pelvis_tx (the horizontal root position is the
                   integral of the estimated horizontal root velocity)
u           9      generalized speeds
qdd         9      generalized accelerations
tau         6      joint torques
contact     14     ``grf: contact_model`` (the paper's): per foot (r, l) the ankle
                   [x − pelvis_tx, y, vx, vy, ax, ay] estimated separately from the
                   kinematic chain and the friction factor μ̂; the GRF is the contact
                   model's (:func:`sspinn.model.dynamics.contact_from_ankles`)
grf         4      ``grf: direct`` (not in the paper): the GRF itself,
                   [F_x, F_y] per foot, F_y = BW·softplus(raw) ≥ 0, F_x = BW/2·raw
grf_points  8      ``grf: two_point`` (the paper's two-fixed-point ablation with force
                   outputs): [F_x, F_y] at the toe, then at the heel, per foot, each
                   scaled by half the body weight, F_y ≥ 0 as above
==========  =====  ====================================================================

Why the direct GRF (:attr:`NetworkConfig.grf`): the paper's contact model makes the vertical
force a stiff function of the estimated ankle height (1 BW per centimetre of penetration), so a
network output must be right to a millimetre for the force to be right to a few per cent of
body weight; and the labels' own kinematics pass through the model's (assumed, Winter-scaled)
feet a few centimetres off the floor, so the true motion is far from the losses' optimum. With
the forces as outputs, the translational rows of the equations of motion tie them linearly to
the measured accelerations, and the contact conditions become losses on the body model's own
feet (:mod:`sspinn.estimator.losses`, L_S and the friction cone) — the contact-implicit formulation of
trajectory optimisation (Posa, Cantu & Tedrake 2014, Int. J. Robot. Res. 33:69–81).

Raw outputs are dimensionless; :func:`decode` scales them by body size (height, body weight)
and typical gait magnitudes so that a unit output is a plausible amount of each quantity.
Inputs (:func:`input_features`: the IMU signals, then height, mass and IMU placement) are
normalised with per-channel statistics stored in the model (buffers), so a saved model
(:mod:`sspinn.estimator.model_store`) carries everything it needs.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn

from sspinn.model.conventions import GRF, N_Q, N_TAU, SEGMENTS

#: The ground-contact outputs of :attr:`NetworkConfig.grf`: name → number of outputs.
GRF_OUTPUTS: dict[str, int] = {"contact_model": 14, "direct": 4, "two_point": 8}
#: The :attr:`NetworkConfig.grf` layouts whose outputs are forces (no separately estimated ankles).
FORCE_OUTPUTS: tuple[str, ...] = ("direct", "two_point")
#: Outputs before the ground-contact block: q without pelvis_tx, u, q̈, τ.
N_BODY_OUTPUTS = (N_Q - 1) + N_Q + N_Q + N_TAU
assert N_BODY_OUTPUTS == 32


@dataclass(frozen=True)
class NetworkConfig:
    """LSTM size and output layout. Defaults are the paper's; ``configs/sspinn/demo.yaml`` uses
    a CPU-sized one.

    Attributes:
        hidden, layers, dropout, dense: the LSTM's units per layer, its layers and the dropout
            between them, and the dense layer's units.
        bidirectional: an offline network that reads the recording both ways (cannot stream).
        body_inputs: read the subject's height, mass and IMU placement besides the IMU signals
            (the paper's θ_b and θ_IMU). False: the IMU signals only — the constants stay in
            the input layout (:func:`input_features`) but are normalised to 0
            (:meth:`SSPINNposeNet.set_normalisation`), so that a subject taller or shorter
            than every training subject is not an input the network never saw.
        grf: ``"contact_model"`` (the paper's: separately estimated ankle kinematics and a
            friction factor drive the contact model), ``"direct"`` (the ground reaction forces
            are outputs; see the module docstring) or ``"two_point"`` (forces at two contact
            points fixed on each foot, toe and heel, as outputs: the paper's "two fixed contact
            points" ablation in the direct formulation; their sum is the foot's GRF).
        sensor_presence: one presence flag per IMU (1 present, 0 missing) as an extra input, and
            a missing IMU's normalised channels set to 0 (the training mean), so that one model
            serves any subset of its IMUs (trained with ``TrainConfig.sensor_dropout``; see
            :meth:`SSPINNposeNet.forward`). Not in the paper.
    """

    hidden: int = 512
    layers: int = 2
    dropout: float = 0.4
    dense: int = 128
    bidirectional: bool = False
    body_inputs: bool = True
    grf: str = "contact_model"
    sensor_presence: bool = False

    def __post_init__(self) -> None:
        if self.hidden < 1 or self.layers < 1 or self.dense < 1:
            raise ValueError(f"network sizes must be positive: {self}")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"dropout must be in [0, 1), got {self.dropout}")
        if self.grf not in GRF_OUTPUTS:
            raise ValueError(f"grf must be one of {list(GRF_OUTPUTS)}, got {self.grf!r}")

    @property
    def n_outputs(self) -> int:
        """Outputs per time step: 46 (contact model) or 36 (direct GRF)."""
        return N_BODY_OUTPUTS + GRF_OUTPUTS[self.grf]


@dataclass
class Estimate:
    """Decoded network outputs, each (..., T, n) in SI units (see the module docstring).

    ``ankle`` and ``mu_hat`` are the contact model's inputs (``grf: contact_model``; else None),
    ``grf`` the forces of a direct-GRF network (else None: the contact model gives them)."""

    q: torch.Tensor  # (..., T, 9), pelvis_tx integrated from u
    u: torch.Tensor  # (..., T, 9)
    qdd: torch.Tensor  # (..., T, 9)
    tau: torch.Tensor  # (..., T, 6)
    ankle: torch.Tensor | None = None  # (..., T, 2, 6): [x − pelvis_tx, y, vx, vy, ax, ay] per foot (r, l)
    mu_hat: torch.Tensor | None = None  # (..., T, 2)
    grf: torch.Tensor | None = None  # (..., T, 4): [Fx_r, Fy_r, Fx_l, Fy_l], N
    grf_points: torch.Tensor | None = None  # (..., T, 2, 2, 2): foot (r, l), point (toe, heel), [Fx, Fy], N ("two_point")

    def ankle_global(self) -> torch.Tensor:
        """(..., T, 8): [x, y, vx, vy] per foot with x made global by adding pelvis_tx."""
        if self.ankle is None:
            raise ValueError("a direct-GRF estimate has no separately estimated ankles")
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
    """LSTM → dense(128) → 46 (or 36) outputs per time step (see the module docstring).

    Args:
        n_inputs: features per time step (IMU channels + constants).
        config: network sizes.
    """

    def __init__(self, n_inputs: int, config: NetworkConfig = NetworkConfig()) -> None:
        super().__init__()
        self.config = config
        self.n_inputs = n_inputs
        #: IMUs of the input layout (:func:`input_features`: 3 channels and 3 placement values each, 2 body constants)
        self.n_imus = (n_inputs - 2) // 6
        if config.sensor_presence and n_inputs != 6 * self.n_imus + 2:
            raise ValueError(f"{n_inputs} input features are not the layout of input_features (6 per IMU + 2)")
        self.lstm = nn.LSTM(
            n_inputs + (self.n_imus if config.sensor_presence else 0),
            config.hidden,
            num_layers=config.layers,
            dropout=config.dropout if config.layers > 1 else 0.0,
            batch_first=True,
            bidirectional=config.bidirectional,
        )
        width = config.hidden * (2 if config.bidirectional else 1)
        self.head = nn.Sequential(nn.Linear(width, config.dense), nn.ELU(), nn.Linear(config.dense, config.n_outputs))
        self.register_buffer("input_mean", torch.zeros(n_inputs))
        self.register_buffer("input_std", torch.ones(n_inputs))

    def set_normalisation(
        self, mean: torch.Tensor, std: torch.Tensor, floor: torch.Tensor | None = None, constants: int = 0
    ) -> None:
        """Per-feature statistics of the training inputs, the std at least ``floor``
        (:func:`feature_std_floor`); ``constants``: how many trailing features are the
        subject's constants (:func:`input_features`), which a network without
        :attr:`~NetworkConfig.body_inputs` must not read (their std is :data:`UNSEEN_STD`).

        A feature that did not vary in training at all (std ≤ 1e-6 × max(1, |mean|), e.g. the
        IMU placement when every training recording has the same) gets std :data:`UNSEEN_STD`:
        the network sees 0 for it whatever its value, since it cannot have learned what a change
        of it means. The floor keeps a feature that varied little in training (four synthetic
        subjects of 1.77 ± 0.01 m) from becoming an input of 13 σ on a 1.90 m subject, which
        saturated the LSTM on real data."""
        self.input_mean.copy_(mean)
        constant = std <= 1e-6 * mean.abs().clamp_min(1.0)
        if not self.config.body_inputs and constants:
            constant[-constants:] = True
        floored = std if floor is None else torch.maximum(std, floor.to(std))
        self.input_std.copy_(torch.where(constant, torch.full_like(std, UNSEEN_STD), floored))

    def forward(
        self, x: torch.Tensor, state: tuple[torch.Tensor, torch.Tensor] | None = None, present: torch.Tensor | None = None
    ) -> tuple[torch.Tensor, tuple[torch.Tensor, torch.Tensor]]:
        """x (B, T, n_inputs) in physical units → raw outputs (B, T, n_outputs) and the LSTM state.

        ``present`` (B, n_imus), 1 for a present and 0 for a missing IMU (None: all present),
        is only for a network with :attr:`~NetworkConfig.sensor_presence`: a missing IMU's
        normalised channels become 0 whatever ``x`` holds there, and the flags are appended to
        the normalised inputs."""
        if x.shape[-1] != self.n_inputs:
            raise ValueError(f"expected {self.n_inputs} input features, got {x.shape[-1]}")
        z = (x - self.input_mean) / self.input_std
        if self.config.sensor_presence:
            flags = torch.ones(x.shape[0], self.n_imus, dtype=z.dtype, device=z.device) if present is None else present.to(z)
            n = 3 * self.n_imus
            channels = z[..., :n] * flags.repeat_interleave(3, dim=-1)[:, None, :]
            z = torch.cat([channels, z[..., n:], flags[:, None, :].expand(-1, z.shape[1], -1)], dim=-1)
        elif present is not None:
            raise ValueError("this network has no sensor presence inputs (NetworkConfig.sensor_presence); it needs all its IMUs")
        h, state = self.lstm(z, state)
        return self.head(h), state

    def hyperparameters(self) -> dict:
        return {"n_inputs": self.n_inputs, **asdict(self.config)}


#: Typical magnitudes of the generalized speeds (m/s, m/s, then rad/s) and accelerations
#: (m/s², m/s², then rad/s²) in gait: the output scales, also used to normalise losses.
TYPICAL_U: tuple[float, ...] = (1.5, 0.5) + (4.0,) * 7
TYPICAL_QDD: tuple[float, ...] = (10.0, 10.0) + (50.0,) * 7

#: Blocks of the outputs (see the module docstring); "contact" or "grf" by :attr:`NetworkConfig.grf`.
BLOCKS = {"q": slice(0, 8), "u": slice(8, 17), "qdd": slice(17, 26), "tau": slice(26, 32), "contact": slice(32, 46), "grf": slice(32, 36),
          "grf_points": slice(32, 40)}
#: Output positions of a direct-GRF network's vertical forces (F_y of the right and left foot,
#: in the order of :data:`sspinn.model.conventions.GRF`), which pass through a softplus (F_y ≥ 0).
VERTICAL_FORCE_OUTPUTS: tuple[int, ...] = tuple(BLOCKS["grf"].start + GRF.index(f) for f in ("grf_y_r", "grf_y_l"))
#: Output positions of a ``two_point`` network's vertical forces (per foot r, l: toe, heel),
#: which pass through a softplus.
VERTICAL_POINT_FORCE_OUTPUTS: tuple[int, ...] = tuple(BLOCKS["grf_points"].start + 2 * k + 1 for k in range(4))
#: Scale of a direct-GRF network's horizontal forces, in body weights per unit raw output.
GRF_X_SCALE = 0.5


def output_affine(height: float, mass: float, leg_length: float, gravity: float = 9.81, grf: str = "contact_model") -> tuple[np.ndarray, np.ndarray]:
    """(scale, offset), each (n_outputs,): physical output = raw · scale + offset for one
    subject (for a direct-GRF network, after the softplus of the vertical forces' raw outputs).

    Lengths scale with height, torques with m·g·h (10 %BW·BH ≈ 120 N·m at 1.75 m, 70 kg), rates
    and accelerations with typical gait magnitudes, forces with the body weight; pelvis_ty is
    offset by the standing hip height ``leg_length`` and the ankle heights by the standing ankle
    height (≈ 0.039·height).
    """
    weight = mass * gravity
    torque = 0.1 * weight * height
    q = [0.05 * height] + [0.5] * 7
    u = list(TYPICAL_U)
    qdd = list(TYPICAL_QDD)
    body = q + u + qdd + [torque] * N_TAU
    ankle = [0.2 * height, 0.05 * height, 2.0, 1.0, 20.0, 20.0, 1.0]
    if grf == "direct":
        contact = [GRF_X_SCALE * weight, weight] * 2
    elif grf == "two_point":  # each point carries about half the foot's load
        contact = [0.5 * GRF_X_SCALE * weight, 0.5 * weight] * 4
    else:
        contact = ankle + ankle
    scale = np.array(body + contact)
    offset = np.zeros(scale.size)
    offset[0] = leg_length
    if grf not in FORCE_OUTPUTS:  # the ankle heights (y, the second output of each foot's block)
        start = BLOCKS["contact"].start
        offset[start + 1] = offset[start + len(ankle) + 1] = 0.039 * height
    return scale, offset


def decode(raw: torch.Tensor, scale: torch.Tensor, offset: torch.Tensor, dt: float, grf: str = "contact_model") -> Estimate:
    """Raw outputs (B, T, n_outputs) of a ``grf`` network → :class:`Estimate`, with
    per-sequence ``scale``/``offset`` (B, n_outputs) from :func:`output_affine`; pelvis_tx is the
    cumulative (trapezoidal) integral of the estimated horizontal root velocity, starting at 0
    in each sequence."""
    if grf in FORCE_OUTPUTS:  # vertical forces ≥ 0
        block = BLOCKS["grf" if grf == "direct" else "grf_points"]
        f = [raw[..., k] for k in range(block.start, block.stop)]
        for k in VERTICAL_FORCE_OUTPUTS if grf == "direct" else VERTICAL_POINT_FORCE_OUTPUTS:
            f[k - block.start] = nn.functional.softplus(f[k - block.start])
        raw = torch.cat([raw[..., : block.start], torch.stack(f, dim=-1)], dim=-1)
    scaled = raw * scale[:, None, :] + offset[:, None, :]
    vx = scaled[..., BLOCKS["u"].start]
    tx = torch.cat([torch.zeros_like(vx[:, :1]), torch.cumsum(0.5 * (vx[:, 1:] + vx[:, :-1]) * dt, dim=1)], dim=1)
    body = {
        "q": torch.cat([tx[..., None], scaled[..., BLOCKS["q"]]], -1),
        "u": scaled[..., BLOCKS["u"]],
        "qdd": scaled[..., BLOCKS["qdd"]],
        "tau": scaled[..., BLOCKS["tau"]],
    }
    if grf == "direct":
        return Estimate(**body, grf=scaled[..., BLOCKS["grf"]])
    if grf == "two_point":
        points = scaled[..., BLOCKS["grf_points"]].reshape(*scaled.shape[:-1], 2, 2, 2)
        return Estimate(**body, grf=points.sum(dim=-2).flatten(-2), grf_points=points)
    contact = scaled[..., BLOCKS["contact"]].reshape(*scaled.shape[:-1], 2, 7)
    return Estimate(**body, ankle=contact[..., :6], mu_hat=contact[..., 6])

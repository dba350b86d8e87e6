"""Running a trained SSPINNpose model: whole recordings and sample-by-sample streaming.

* :func:`estimate_recording` — a recording in, a :class:`GaitEstimate` out (no labels needed).
* :class:`StreamingEstimator` — one IMU sample in, the estimate at that sample out, with the
  LSTM state carried between calls (the real-time use of the unidirectional network).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from sspinn import dynamics
from sspinn._generated import model_numba
from sspinn.body import BodyParameters, IMUPlacement
from sspinn.contact import ContactParameters
from sspinn.conventions import COORDINATES, GRF, JOINTS
from sspinn.dataset import SAMPLE_RATE_HZ, DataFormatError, Recording
from sspinn.network import BLOCKS, SSPINNposeNet, decode, output_affine, split_outputs
from sspinn.training import input_features


@dataclass
class GaitEstimate:
    """Estimated gait of one recording; arrays over T samples at 100 Hz, SI units.

    q, u, qdd (T, 9); tau (T, 6) N·m; grf (T, 4) N; w (T, 2); ankle (T, 2, 6); mu_hat (T, 2).
    """

    name: str
    time: np.ndarray
    q: np.ndarray
    u: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    grf: np.ndarray
    w: np.ndarray
    ankle: np.ndarray
    mu_hat: np.ndarray

    def columns(self) -> dict[str, np.ndarray]:
        cols = {"time": self.time}
        cols |= {c: self.q[:, i] for i, c in enumerate(COORDINATES)}
        cols |= {f"d_{c}": self.u[:, i] for i, c in enumerate(COORDINATES)}
        cols |= {f"dd_{c}": self.qdd[:, i] for i, c in enumerate(COORDINATES)}
        cols |= {f"tau_{j}": self.tau[:, i] for i, j in enumerate(JOINTS)}
        cols |= {g: self.grf[:, i] for i, g in enumerate(GRF)}
        cols |= {"w_r": self.w[:, 0], "w_l": self.w[:, 1]}
        return cols

    def to_csv(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        cols = self.columns()
        np.savetxt(path, np.column_stack(list(cols.values())), delimiter=",", header=",".join(cols), comments="", fmt="%.7g")
        return path


def _check_segments(rec: Recording, segments: tuple[str, ...]) -> Recording:
    missing = [s for s in segments if s not in rec.segments]
    if missing:
        raise DataFormatError(f"{rec.name}: the model needs IMUs on {list(segments)}; missing {missing}")
    return rec.select_imus(segments)


def _outputs(raw: torch.Tensor, body: BodyParameters) -> dict[str, torch.Tensor]:
    """Decode raw outputs (1, T, 46) and evaluate the contact model (float64)."""
    scale, offset = output_affine(body.height, body.mass, body.standing_hip_height, body.gravity)
    est = decode(raw.double(), torch.as_tensor(scale)[None], torch.as_tensor(offset)[None], 1.0 / SAMPLE_RATE_HZ)
    pt = torch.as_tensor(body.vector())
    c = torch.as_tensor(ContactParameters().vector())
    gc = dynamics.contact_from_ankles(est.q, est.u, est.ankle_global(), est.mu_hat, pt, c)
    return {
        "q": est.q, "u": est.u, "qdd": est.qdd, "tau": est.tau, "ankle": est.ankle, "mu_hat": est.mu_hat,
        "grf": gc[..., :2].flatten(-2), "w": dynamics.contact_fraction(est.q, c),
    }


@torch.no_grad()
def estimate_recording(model: SSPINNposeNet, rec: Recording, segments: tuple[str, ...], placement: np.ndarray | None = None) -> GaitEstimate:
    """Run the model over a whole recording (the assumed body: Winter scaling of its height and
    mass; the nominal IMU placement unless ``placement`` (21,) is given)."""
    rec = _check_segments(rec, segments)
    model.eval()
    device = next(model.parameters()).device
    placement = rec.placement.vector() if placement is None else placement
    x = input_features(rec.imu, rec.height, rec.mass, placement, segments)
    raw, _ = model(torch.as_tensor(x, dtype=torch.float32, device=device)[None])
    body = BodyParameters.from_anthropometry(rec.height, rec.mass)
    out = {k: v[0].cpu().numpy() for k, v in _outputs(raw.cpu(), body).items()}
    return GaitEstimate(name=rec.name, time=rec.time, **out)


class StreamingEstimator:
    """Sample-by-sample estimation with a carried LSTM state (unidirectional models only).

    Args:
        model: a trained unidirectional model.
        segments: its IMU segments.
        height, mass: the subject (m, kg).
        placement: (21,) IMU placement, default the scaled nominal one.
    """

    def __init__(self, model: SSPINNposeNet, segments: tuple[str, ...], height: float, mass: float, placement: np.ndarray | None = None) -> None:
        if model.config.bidirectional:
            raise ValueError("a bidirectional model needs the whole sequence; it cannot stream")
        self.model = model.eval()
        self.segments = segments
        self.height, self.mass = height, mass
        self.placement = IMUPlacement.default(height).vector() if placement is None else placement
        body = BodyParameters.from_anthropometry(height, mass)
        self.p = body.vector()
        self.c = ContactParameters().vector()
        self.scale, self.offset = output_affine(height, mass, body.standing_hip_height, body.gravity)
        self.reset()

    def reset(self) -> None:
        self.state = None
        self.x_root = 0.0
        self.vx_previous: float | None = None

    @torch.no_grad()
    def step(self, sample: np.ndarray) -> dict[str, np.ndarray]:
        """One sample (n_imu, 3) [acc_x, acc_y, gyr_z] in the model's segment order → dict of
        q (9), u (9), qdd (9), tau (6), grf (4), w (2) at that sample (NumPy, SI units).

        The network runs in torch (oneDNN off: its per-call overhead dominates single-step
        LSTMs on CPU, see ../shared/TRAPS.md); decoding and the contact model run on NumPy and
        the generated numba kernel, so the physics adds microseconds, not milliseconds.
        """
        sample = np.asarray(sample, dtype=np.float64)
        if sample.shape != (len(self.segments), 3) or not np.isfinite(sample).all():
            raise ValueError(f"expected a finite ({len(self.segments)}, 3) sample for IMUs {self.segments}, got {sample.shape}")
        x = input_features(sample[None], self.height, self.mass, self.placement, self.segments)
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="TF32 acceleration")  # torch's notice on toggling oneDNN
            with torch.backends.mkldnn.flags(enabled=False):
                raw, self.state = self.model(torch.as_tensor(x, dtype=torch.float32)[None], self.state)
        scaled = raw[0, -1].double().numpy() * self.scale + self.offset
        vx = scaled[BLOCKS["u"].start]
        if self.vx_previous is not None:  # trapezoidal integral, as in network.decode
            self.x_root += 0.5 * (vx + self.vx_previous) / SAMPLE_RATE_HZ
        self.vx_previous = vx
        out = split_outputs(scaled, np.array(self.x_root))
        ankle = np.ascontiguousarray(out["ankle"][:, :4].copy())
        ankle[:, 0] += self.x_root
        gc, w = np.empty((2, 6)), np.empty(2)
        model_numba.contact_learned_from_ankles(out["q"], out["u"], ankle.reshape(-1), np.ascontiguousarray(out["mu_hat"]), self.p, self.c, gc, w)
        out["grf"] = gc[:, :2].reshape(-1)
        out["w"] = w
        return out

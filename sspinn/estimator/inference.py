"""Running a trained SSPINNpose model: whole recordings and sample-by-sample streaming.

* :func:`estimate_recording` — a recording in, a :class:`GaitEstimate` out (no labels needed).
* :class:`StreamingEstimator` — one IMU sample in, the estimate at that sample out, with the
  LSTM state carried between calls (the real-time use of the unidirectional network).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np
import torch

from sspinn.data.dataset import SAMPLE_RATE_HZ, DataFormatError, Recording
from sspinn.errors import UserError
from sspinn.estimator.load_transfer import linear_load_transfer
from sspinn.estimator.network import (
    BLOCKS,
    VERTICAL_FORCE_OUTPUTS,
    SSPINNposeNet,
    decode,
    input_features,
    output_affine,
)
from sspinn.estimator.zupt import speed_with_rests
from sspinn.model import dynamics
from sspinn.model._generated import model_numba
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import GRAVITY
from sspinn.model.trajectory import Trajectory
from sspinn.run_folder import atomic_path


class NonFiniteEstimateError(UserError):
    """The network produced NaN or inf for a recording; nothing is written."""


class ImplausibleEstimateError(UserError):
    """The network's estimate is physically impossible for a human (see :data:`PHYSICAL_LIMITS`)."""


#: Bounds no human gait exceeds (far beyond sprinting and landing values), used by
#: :meth:`GaitEstimate.check_physical`: |pelvis tilt and joint angles| (rad), pelvis height
#: (× body height), |forward pelvis speed| (m/s), |GRF| per component (× body weight),
#: |joint torque| (N·m per kg of body mass).
PHYSICAL_LIMITS: dict[str, float] = {
    "angle_rad": math.pi, "pelvis_height_per_height": 1.0, "speed_m_s": 15.0, "grf_bw": 20.0, "torque_nm_per_kg": 20.0,
}


@dataclass(kw_only=True)
class GaitEstimate(Trajectory):
    """Estimated gait of one recording: a :class:`~sspinn.model.trajectory.Trajectory` over T samples
    at 100 Hz (time, q, u, qdd (T, 9); tau (T, 6) N·m; grf (T, 4) N; w (T, 2); SI units; built
    with keywords) with the recording's ``name``.
    """

    name: str

    def check_finite(self) -> GaitEstimate:
        """``self`` if every estimated value is finite, else :class:`NonFiniteEstimateError`
        naming the quantity and the first sample."""
        bad = self.non_finite()
        if bad is not None:
            name, k, count = bad
            raise NonFiniteEstimateError(
                f"{self.name}: the estimate's {name} is not finite from sample {k} on ({count} values); "
                "nothing written: the model may be damaged or diverged (retrain it), or the recording is far "
                "outside what it was trained on"
            )
        return self

    def check_physical(self, height: float, mass: float) -> GaitEstimate:
        """``self`` if it stays within :data:`PHYSICAL_LIMITS` for a subject of ``height`` (m)
        and ``mass`` (kg), else :class:`ImplausibleEstimateError` naming the quantity, the
        sample and the value."""
        lim, weight = PHYSICAL_LIMITS, mass * GRAVITY
        checks = (
            ("pelvis tilt / joint angle", "rad", np.abs(self.q[:, 2:]), lim["angle_rad"]),
            ("pelvis height below ground", "m", -self.q[:, 1:2], 0.0),
            ("pelvis height", "m", self.q[:, 1:2], lim["pelvis_height_per_height"] * height),
            ("forward pelvis speed", "m/s", np.abs(self.u[:, :1]), lim["speed_m_s"]),
            ("ground reaction force", "N", np.abs(self.grf), lim["grf_bw"] * weight),
            ("joint torque", "N·m", np.abs(self.tau), lim["torque_nm_per_kg"] * mass),
        )
        for what, unit, values, bound in checks:
            if (values > bound).any():
                k, j = np.unravel_index(int(np.argmax(values)), values.shape)
                raise ImplausibleEstimateError(
                    f"{self.name}: the estimated {what} reaches {values[k, j]:.4g} {unit} at sample {k}, beyond the "
                    f"{bound:.4g} {unit} no human movement reaches; nothing written: the model is not trained for "
                    "this recording (train longer or on similar data) or the inputs are wrong"
                )
        return self

    def to_csv(self, path: str | Path) -> Path:
        """Write the estimate as CSV (time and the trajectory's :meth:`~sspinn.model.trajectory.Trajectory.columns`;
        atomically; refused if any value is not finite)."""
        path = Path(path)
        self.check_finite()
        cols = self.columns()
        with atomic_path(path) as tmp:
            np.savetxt(tmp, np.column_stack(list(cols.values())), delimiter=",", header=",".join(cols), comments="", fmt="%.7g")
        return path


@dataclass
class NetworkInputs:
    """What the network reads of one recording (:func:`network_inputs`).

    Attributes:
        x: (1, T, n_inputs) features (:func:`~sspinn.estimator.network.input_features`), zeros in
            the channels of a missing IMU.
        present: (1, n_imus) presence flags for a network with sensor presence inputs, None when
            every IMU of the model is there.
        recording: the recording with the model's IMUs it has, in the model's order.
    """

    x: torch.Tensor
    present: torch.Tensor | None
    recording: Recording


def network_inputs(model: SSPINNposeNet, rec: Recording, segments: tuple[str, ...], placement: np.ndarray | None = None) -> NetworkInputs:
    """The model's inputs for ``rec`` (its IMUs on ``segments``; the nominal placement unless
    ``placement`` (21,) is given). A recording without some of them is an error, unless the
    model has presence inputs (:attr:`~sspinn.estimator.network.NetworkConfig.sensor_presence`):
    then the missing ones are flagged absent."""
    missing = [s for s in segments if s not in rec.segments]
    if missing and not (model.config.sensor_presence and len(missing) < len(segments)):
        hint = "" if model.config.sensor_presence else (
            "; a model trained with sensor_dropout > 0 accepts any subset of its IMUs")
        raise DataFormatError(f"{rec.name}: the model needs IMUs on {list(segments)}; missing {missing}{hint}")
    have = rec.select_imus([s for s in segments if s in rec.segments])
    imu = np.zeros((rec.n_samples, len(segments), 3))
    idx = [segments.index(s) for s in have.segments]
    imu[:, idx] = have.imu
    placement = rec.placement.vector() if placement is None else placement
    device = next(model.parameters()).device
    x = torch.as_tensor(input_features(imu, rec.height, rec.mass, placement, segments), dtype=torch.float32, device=device)[None]
    present = None
    if missing:
        flags = np.isin(np.array(segments), have.segments).astype(np.float32)
        present = torch.as_tensor(flags, device=device)[None]
    return NetworkInputs(x, present, have)


def physical_outputs(raw: torch.Tensor, body: BodyParameters, grf: str) -> dict[str, torch.Tensor]:
    """Decode the raw outputs (B, T, n_outputs) of a ``grf`` network for one subject and, for the
    paper's, evaluate the contact model (float64): q, u, qdd, tau, grf and w, each (B, T, n)."""
    scale, offset = output_affine(body.height, body.mass, body.standing_hip_height, body.gravity, grf)
    est = decode(raw.double(), torch.as_tensor(scale)[None], torch.as_tensor(offset)[None], 1.0 / SAMPLE_RATE_HZ, grf)
    c = torch.as_tensor(ContactParameters().vector())
    if est.grf is None:
        gc = dynamics.contact_from_ankles(est.q, est.u, est.ankle_global(), est.mu_hat, torch.as_tensor(body.vector()), c)
        est.grf = gc[..., :2].flatten(-2)
    w = dynamics.contact_fraction(est.q, c)
    if est.grf_points is not None:  # two points per foot: where their vertical loads balance (toe 0, heel 1)
        fy = est.grf_points[..., 1]
        total = fy.sum(dim=-1)
        w = torch.where(total > 1e-3, fy[..., 1] / total.clamp_min(1e-3), w)
    return {"q": est.q, "u": est.u, "qdd": est.qdd, "tau": est.tau, "grf": est.grf, "w": w}


@torch.no_grad()
def estimate_recording(model: SSPINNposeNet, rec: Recording, segments: tuple[str, ...], placement: np.ndarray | None = None,
                       load_transfer: bool = False) -> GaitEstimate:
    """Run the model over a whole recording (the assumed body: Winter scaling of its height and
    mass; the nominal IMU placement unless ``placement`` (21,) is given). A model with presence
    inputs accepts a recording with a subset of its IMUs (:func:`network_inputs`). With
    ``load_transfer`` the vertical GRF of each double support moves from the trailing to the
    leading foot at a constant rate, the torques following
    (:func:`~sspinn.estimator.load_transfer.linear_load_transfer`; offline, off by default).

    Where every IMU rests for at least half a second (:func:`~sspinn.estimator.zupt.whole_body_still`:
    standing or sitting still), the forward pelvis velocity is set to 0 and pelvis_tx integrated
    again: a whole-body zero-velocity update. The network cannot tell a body at rest from one
    gliding at constant speed (the accelerometers read the same; its training data have no
    standing), and reported 0.3–0.6 m/s in real quiet standing. The speed stays continuous at a
    rest's edges: the network's offset there decays with :data:`~sspinn.estimator.zupt.REST_EDGE_TAU_S`
    (:func:`~sspinn.estimator.zupt.speed_at_rest`). Walking and running never rest every segment
    that long, so their estimates are unchanged. The stream
    (:class:`StreamingEstimator`) has no look-ahead and makes no such update."""
    model.eval()
    inputs = network_inputs(model, rec, segments, placement)
    raw, _ = model(inputs.x, present=inputs.present)
    body = BodyParameters.from_anthropometry(rec.height, rec.mass)
    out = {k: v[0].cpu().numpy() for k, v in physical_outputs(raw.cpu(), body, model.config.grf).items()}
    # the network's own output is checked first: an impossible speed is an error, not a rest
    estimate = GaitEstimate(name=rec.name, time=rec.time, **out).check_finite().check_physical(rec.height, rec.mass)
    vx, still = speed_with_rests(estimate.u[:, 0], inputs.recording.imu, SAMPLE_RATE_HZ)
    if still.any():
        estimate.u[:, 0] = vx
        estimate.q[:, 0] = np.concatenate([[0.0], np.cumsum(0.5 * (vx[1:] + vx[:-1]) / SAMPLE_RATE_HZ)])
    if load_transfer:
        estimate = linear_load_transfer(estimate, body, SAMPLE_RATE_HZ)
    return estimate


# Streaming: a hand-written single-step LSTM (see StreamingEstimator for why it exists).
# fastmath without nnan/ninf: reassociation lets LLVM vectorise the dot products, while
# non-finite values still propagate as in torch.
_FASTMATH = {"reassoc", "contract", "nsz", "arcp"}
#: StreamingEstimator's result buffer: q, u, qdd, tau, grf, w, then (contact model only) the
#: ankles (2, 6) and mu_hat.
_N_RESULT = 9 + 9 + 9 + 6 + 4 + 2 + 12 + 2


@numba.njit(fastmath=_FASTMATH, cache=True)
def _lstm_layer(w, b, a, h, c, gates):  # pragma: no cover - compiled (tested through step)
    """One time step of one LSTM layer, state (h, c) updated in place.

    ``w`` (4H, n_a + H) is [W_ih | W_hh] and ``b`` (4H,) b_ih + b_hh, both with rows reordered
    so that rows 4j..4j+3 are the gates (i, f, g, o) of unit j: one pass over the weights with
    four vectorised accumulators. The cell update runs in a second loop over ``gates`` (4H,)
    scratch (fusing it into the first made LLVM's code ~3× slower).
    """
    n_a = a.shape[0]
    n_h = h.shape[0]
    for j in range(n_h):
        r = 4 * j
        si, sf, sg, so = b[r], b[r + 1], b[r + 2], b[r + 3]
        for m in range(n_a):
            v = a[m]
            si += w[r, m] * v
            sf += w[r + 1, m] * v
            sg += w[r + 2, m] * v
            so += w[r + 3, m] * v
        for m in range(n_h):
            v = h[m]
            k = n_a + m
            si += w[r, k] * v
            sf += w[r + 1, k] * v
            sg += w[r + 2, k] * v
            so += w[r + 3, k] * v
        gates[r], gates[r + 1], gates[r + 2], gates[r + 3] = si, sf, sg, so
    for j in range(n_h):
        r = 4 * j
        gi = 1.0 / (1.0 + math.exp(-gates[r]))
        gf = 1.0 / (1.0 + math.exp(-gates[r + 1]))
        go = 1.0 / (1.0 + math.exp(-gates[r + 3]))
        cj = gf * c[j] + gi * math.tanh(gates[r + 2])
        c[j] = cj
        h[j] = go * math.tanh(cj)


@numba.njit(fastmath=_FASTMATH, cache=True)
def _dense(w, b, a, out, elu):  # pragma: no cover - compiled
    """out = w @ a + b, then ELU (α = 1) if ``elu``."""
    for i in range(w.shape[0]):
        s = b[i]
        for m in range(a.shape[0]):
            s += w[i, m] * a[m]
        out[i] = (s if s > 0.0 else math.expm1(s)) if elu else s


@numba.njit(cache=True)
def _network_step(
    x, mean, std, w0, b0, wr, br, h, c, gates, wd, bd, wo, bo, dense, raw, scale, offset, dt, root, res, ankle_global, direct,
    vertical, vx_at, n_body,
):  # pragma: no cover - compiled (tested through StreamingEstimator.step)
    """One sample through the network and the decoding; False (and nothing changed) if ``x``
    is not finite.

    x (n_imu·3,) float64 IMU channels; mean/std their input statistics; w0/b0 the first layer
    with the subject's constant inputs folded into b0; wr/br (layers − 1, ...) the others;
    h/c (layers, H) the carried state; dt the sample period; root [pelvis_tx, previous vx, started];
    ``direct``: a direct-GRF network (``network.decode``). The output layout comes from
    :data:`sspinn.estimator.network.BLOCKS`: ``vertical`` the outputs with a softplus
    (``VERTICAL_FORCE_OUTPUTS``), ``vx_at`` the horizontal root velocity's output, ``n_body`` the
    end of the body block (q[1:], u, qdd, tau), which the ground-contact block follows. Writes
    ``res`` (q, u, qdd, tau; then the GRF of a direct-GRF network, else the ankles and mu_hat,
    the GRF and w being left to the contact kernels) and, for the contact model,
    ``ankle_global`` [x, y, vx, vy] per foot.
    """
    n = x.shape[0]
    for k in range(n):
        if not np.isfinite(x[k]):
            return False
    a = np.empty(n, np.float32)
    for k in range(n):
        a[k] = (np.float32(x[k]) - mean[k]) / std[k]
    _lstm_layer(w0, b0, a, h[0], c[0], gates)
    for layer in range(wr.shape[0]):
        _lstm_layer(wr[layer], br[layer], h[layer], h[layer + 1], c[layer + 1], gates)
    _dense(wd, bd, h[h.shape[0] - 1], dense, True)
    _dense(wo, bo, dense, raw, False)
    pre = raw.astype(np.float64)
    for k in vertical:  # vertical forces of a direct-GRF network: softplus, as torch's (threshold 20)
        pre[k] = pre[k] if pre[k] > 20.0 else math.log1p(math.exp(pre[k]))
    scaled = pre * scale + offset
    vx = scaled[vx_at]  # u[0], the horizontal root velocity
    if root[2] > 0.0:  # trapezoidal integral, as in network.decode
        root[0] += 0.5 * (vx + root[1]) * dt
    root[1] = vx
    root[2] = 1.0
    res[0] = root[0]
    res[1 : 1 + n_body] = scaled[0:n_body]  # q[1:], u, qdd, tau
    if direct:
        res[1 + n_body : 5 + n_body] = scaled[n_body : n_body + 4]
        return True
    for foot in range(2):  # per foot: ankle [x, y, vx, vy, ax, ay], mu_hat
        a = n_body + 7 * foot
        res[1 + n_body + 6 + 6 * foot : 1 + n_body + 12 + 6 * foot] = scaled[a : a + 6]
        res[1 + n_body + 18 + foot] = scaled[a + 6]
        ankle_global[4 * foot : 4 * foot + 4] = scaled[a : a + 4]
        ankle_global[4 * foot] += root[0]
    return True


class StreamingEstimator:
    """Sample-by-sample estimation with a carried LSTM state (unidirectional models only).

    Args:
        model: a trained unidirectional model (put in eval mode: no dropout).
        segments: its IMU segments.
        height, mass: the subject (m, kg).
        placement: (21,) IMU placement, default the scaled nominal one.

    The network runs in a hand-written single-step LSTM cell (:func:`_network_step`, numba,
    float32 like the torch model) on weights copied from ``model`` at construction and at each
    :meth:`reset` (after training the model further, call :meth:`reset`). Why hand-written: one
    time step at batch 1 is little more than one matrix-vector product per layer (~0.3 ms for
    the paper model, weights read from cache), but stepping ``nn.LSTM`` costs 1–2 ms on one CPU
    thread (7–10 ms with PyTorch's default oneDNN path), most of it per-call overhead, and
    NumPy's ``W @ x`` goes through multi-threaded OpenBLAS, which took ~8 ms for the 2048×1024
    layer on this loaded 2-core machine; no library offers a lean single-step LSTM on CPU. The
    cell fuses each layer's input and recurrent products into one pass over [W_ih | W_hh] with
    a unit's four gate rows interleaved, and folds the constant body/placement inputs (the
    paper's θ_b and θ_IMU, fixed for a subject; see ``network.input_features``) into the first
    layer's bias once per subject, so only the IMU channels are multiplied per sample. Decoding
    runs in the same kernel and the contact model in the generated numba kernel: a step makes
    no torch tensors and allocates one output buffer (the returned arrays are views of it).
    Agreement with the torch model over whole sequences is tested (tests/test_streaming.py).
    """

    def __init__(self, model: SSPINNposeNet, segments: tuple[str, ...], height: float, mass: float, placement: np.ndarray | None = None) -> None:
        if model.config.bidirectional:
            raise ValueError("a bidirectional model needs the whole sequence; it cannot stream")
        if model.config.grf == "two_point":
            raise ValueError("a two_point-GRF model cannot stream (an ablation variant); use estimate_recording")
        self.model = model.eval()
        self.segments = segments
        self.height, self.mass = height, mass
        self.placement = IMUPlacement.default(height).vector() if placement is None else placement
        body = BodyParameters.from_anthropometry(height, mass)
        self.p = body.vector()
        self.c = ContactParameters().vector()
        self.direct = model.config.grf == "direct"
        self._vertical = np.array(VERTICAL_FORCE_OUTPUTS if self.direct else (), dtype=np.int64)
        self.scale, self.offset = output_affine(height, mass, body.standing_hip_height, body.gravity, model.config.grf)
        self.reset()

    def _pack(self) -> None:
        """Copy the model's weights into the layout of :func:`_network_step` (float32)."""
        model, n_imu = self.model, 3 * len(self.segments)
        features = input_features(np.zeros((1, len(self.segments), 3)), self.height, self.mass, self.placement, self.segments)[0]
        if features.size != model.n_inputs:
            raise ValueError(f"the model takes {model.n_inputs} input features; IMUs {self.segments} give {features.size}")

        def arr(t: torch.Tensor) -> np.ndarray:
            return t.detach().to("cpu", torch.float32).numpy()

        def interleave(m: np.ndarray) -> np.ndarray:  # rows (i, f, g, o) × H → H × (i, f, g, o)
            return np.ascontiguousarray(m.reshape(4, -1, *m.shape[1:]).swapaxes(0, 1).reshape(m.shape))

        lstm, cfg = model.lstm, model.config
        mean, std = arr(model.input_mean), arr(model.input_std)
        consts = (features[n_imu:].astype(np.float32) - mean[n_imu:]) / std[n_imu:]
        if model.config.sensor_presence:  # every IMU present: the flags are constant inputs of 1
            consts = np.concatenate([consts, np.ones(len(self.segments), np.float32)])
        w, b = [], []
        for layer in range(cfg.layers):
            w_ih, w_hh = arr(getattr(lstm, f"weight_ih_l{layer}")), arr(getattr(lstm, f"weight_hh_l{layer}"))
            bias = arr(getattr(lstm, f"bias_ih_l{layer}")).astype(np.float64) + arr(getattr(lstm, f"bias_hh_l{layer}"))
            if layer == 0:  # the constant inputs' share of the first layer, once per subject
                bias += w_ih[:, n_imu:].astype(np.float64) @ consts.astype(np.float64)
                w_ih = w_ih[:, :n_imu]
            w.append(interleave(np.concatenate([w_ih, w_hh], axis=1)))
            b.append(interleave(bias.astype(np.float32)))
        H = cfg.hidden
        self._net = dict(
            mean=np.ascontiguousarray(mean[:n_imu]), std=np.ascontiguousarray(std[:n_imu]), w0=w[0], b0=b[0],
            wr=np.ascontiguousarray(np.array(w[1:], dtype=np.float32).reshape(cfg.layers - 1, 4 * H, 2 * H)),
            br=np.ascontiguousarray(np.array(b[1:], dtype=np.float32).reshape(cfg.layers - 1, 4 * H)),
            wd=np.ascontiguousarray(arr(model.head[0].weight)), bd=arr(model.head[0].bias).copy(),
            wo=np.ascontiguousarray(arr(model.head[2].weight)), bo=arr(model.head[2].bias).copy(),
        )
        self._h = np.zeros((cfg.layers, H), np.float32)
        self._c = np.zeros((cfg.layers, H), np.float32)
        self._gates = np.empty(4 * H, np.float32)
        self._dense_out = np.empty(cfg.dense, np.float32)
        self._raw = np.empty(model.config.n_outputs, np.float32)
        self._ankle_global = np.empty(8)
        self._gc = np.empty((2, 6))

    def reset(self) -> None:
        """Start a new stream: zero LSTM state, pelvis_tx 0, weights re-read from the model."""
        self._pack()
        self._root = np.zeros(3)  # pelvis_tx, previous vx, started

    @property
    def x_root(self) -> float:
        """pelvis_tx (m): the integral of the estimated horizontal root velocity so far."""
        return float(self._root[0])

    @property
    def state(self) -> tuple[torch.Tensor, torch.Tensor] | None:
        """The carried LSTM state as torch's (h, c), each (layers, 1, hidden); None before the first step."""
        if not self._root[2]:
            return None
        return torch.from_numpy(self._h.copy())[:, None], torch.from_numpy(self._c.copy())[:, None]

    def step(self, sample: np.ndarray) -> dict[str, np.ndarray]:
        """One sample (n_imu, 3) [acc_x, acc_y, gyr_z] in the model's segment order → dict of
        q (9), u (9), qdd (9), tau (6), grf (4), w (2) and, for the paper's contact model, its
        inputs ankle (2, 6) (x relative to pelvis_tx) and mu_hat (2) at that sample (NumPy, SI units)."""
        sample = np.asarray(sample, dtype=np.float64)
        if sample.shape != (len(self.segments), 3):
            raise ValueError(f"expected a finite ({len(self.segments)}, 3) sample for IMUs {self.segments}, got {sample.shape}")
        net, res = self._net, np.empty(_N_RESULT)
        if not _network_step(
            sample.reshape(-1), net["mean"], net["std"], net["w0"], net["b0"], net["wr"], net["br"], self._h, self._c,
            self._gates, net["wd"], net["bd"], net["wo"], net["bo"], self._dense_out, self._raw, self.scale, self.offset,
            1.0 / SAMPLE_RATE_HZ, self._root, res, self._ankle_global, self.direct, self._vertical, BLOCKS["u"].start,
            BLOCKS["tau"].stop,
        ):
            raise ValueError(f"expected a finite ({len(self.segments)}, 3) sample for IMUs {self.segments}, got non-finite values")
        q, u = res[0:9], res[9:18]
        out = {"q": q, "u": u, "qdd": res[18:27], "tau": res[27:33], "grf": res[33:37], "w": res[37:39]}
        if self.direct:
            model_numba.contact_point_fraction(q, self.c, res[37:39])
            return out
        model_numba.contact_learned_from_ankles(q, u, self._ankle_global, res[51:53], self.p, self.c, self._gc, res[37:39])
        res[33:37].reshape(2, 2)[:] = self._gc[:, :2]
        return {**out, "ankle": res[39:51].reshape(2, 6), "mu_hat": res[51:53]}

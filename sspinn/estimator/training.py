"""Self-supervised training of the SSPINNpose network — readable top to bottom.

1. ``TrainConfig`` (YAML in ``configs/sspinn/``) says what to train on and how.
2. ``WindowSampler`` draws random windows (default 256 samples) from the training recordings.
3. ``Trainer.fit`` runs Adam on the weighted physics losses of :mod:`sspinn.estimator.losses`, with input
   noise augmentation, gradient clipping, a NaN/inf guard that names the offending windows,
   TensorBoard logs, a progress bar, periodic checkpoints, ``resume`` and a checkpoint on Ctrl-C.

No labels are used anywhere in training. A training from scratch stores the means of its
recordings' labels, where they have any, in the model file as the trivial predictors evaluation
compares with (:func:`~sspinn.estimator.trivial_predictors.training_predictor`); they play no part
in the training itself.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import random
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np
import torch
import yaml

from sspinn.data.dataset import SAMPLE_RATE_HZ, Recording
from sspinn.estimator.cpu_share import ThreadShare
from sspinn.estimator.losses import Batch, IMUNoise, LossWeights, PhysicsLosses
from sspinn.estimator.model_store import (
    MODEL_ENTRIES,
    StoredModel,
    baselines_entry,
    load_model,
    load_weights,
    read_baselines,
    save_model,
)
from sspinn.estimator.network import (
    NetworkConfig,
    SSPINNposeNet,
    decode,
    feature_std_floor,
    input_features,
    output_affine,
)
from sspinn.estimator.trivial_predictors import TrivialPredictor, training_predictor
from sspinn.interrupt import DeferredInterrupt
from sspinn.model.backends import ops_for
from sspinn.model.body import BodyParameters, JointLimits
from sspinn.model.conventions import SEGMENTS
from sspinn.run_folder import RunLock, atomic_write_text
from sspinn.torch_files import CHECKPOINT, ModelFileError, check_finite_weights, load_torch_file, save_torch_file
from sspinn.yaml_config import apply_setting, config_from_mapping, load_config, set_option

#: Named IMU configurations: the paper's sets, then single segments (sparse sets keep λ_IMU's
#: relative weight; see losses).
IMU_CONFIGURATIONS: dict[str, tuple[str, ...]] = {
    "all": SEGMENTS,
    "feet_thighs": ("femur_r", "foot_r", "femur_l", "foot_l"),
    "feet_shanks": ("tibia_r", "foot_r", "tibia_l", "foot_l"),
    "shanks_pelvis": ("pelvis", "tibia_r", "tibia_l"),
    "shanks_thighs": ("femur_r", "tibia_r", "femur_l", "tibia_l"),
    # single segments (the paper: "did not lead to meaningful results")
    "pelvis": ("pelvis",),
    "thighs": ("femur_r", "femur_l"),
    "shanks": ("tibia_r", "tibia_l"),
    "feet": ("foot_r", "foot_l"),
}


@dataclass
class TrainConfig:
    """Everything that defines a training run (see ``configs/sspinn/*.yaml``).

    Attributes:
        imus: IMU configuration, a key of :data:`IMU_CONFIGURATIONS`.
        network: LSTM size and ground-contact outputs (:class:`~sspinn.estimator.network.NetworkConfig`).
        weights: loss weights λ (:class:`~sspinn.estimator.losses.LossWeights`).
        imu_noise: divide L_IMU's errors by each channel's expected error
            (:class:`~sspinn.estimator.losses.IMUNoise`) instead of its standard deviation (None, the
            paper's).
        finetune: use the fine-tuning weights (kane, temporal and contact × 10).
        finetune_last: the last this many steps use the fine-tuning weights (the paper's
            fine-tuning as the end of one run; 0 = none).
        learn_placement: also optimise the IMU placement of each training recording (the paper's
            placement optimisation).
        placement_lr_factor: with ``learn_placement``, the placement's learning rate as a fraction
            of the network's (the same schedule). Adam moves each parameter by up to about its
            learning rate per step — 2 mm at the demo's ``lr`` — a coarse step for sensor positions
            that are off by a few centimetres.
        placement_angles: with ``learn_placement``, learn the sensors' in-plane angles too (the
            paper's); False keeps each recording's angles (from the sensor calibration) and learns
            the positions only.
        steps: optimiser steps.
        batch_size: windows per step.
        window: samples per window (>= 8).
        lr: Adam learning rate (the peak, with a schedule).
        lr_schedule: "constant", or "cosine": half a cosine from ``lr`` down to ``lr_final`` over
            ``steps`` (set from the step count every step, so a resumed run follows it exactly;
            with ``starts`` the starts run at ``lr`` and the chosen one continues on the schedule).
        lr_final: the cosine schedule's last learning rate, as a fraction of ``lr``.
        input_noise: η, input noise std as a fraction of each channel's std.
        sensor_dropout: probability that an IMU is missing from a training window's inputs
            (each IMU of each window drawn independently, at least one kept; 0 = never). The
            network then gets presence flags (:attr:`~sspinn.estimator.network.NetworkConfig.sensor_presence`,
            set automatically) and serves any subset of :attr:`imus`; L_IMU still compares all
            the IMUs the training recordings have, so the network learns to reconstruct the
            motion a missing sensor would have measured. Not in the paper.
        grad_clip: gradient-norm clipping threshold.
        seed: seed of the window draws, the noise and the initial weights.
        device: cpu, cuda or auto.
        threads: torch intra-op threads on CPU; 0 = the CPUs not busy with other work, re-measured
            every 1,000 steps (or ``checkpoint_every`` if larger) (:class:`~sspinn.estimator.cpu_share.ThreadShare`).
        log_every: steps between TensorBoard/progress logs.
        checkpoint_every: steps between checkpoints.
        time_limit_s: safety net: stop (with a checkpoint and a loud TimeLimitWarning) after
            this wall time, s; 0 = none.
        amp: bfloat16 autocast of the network on CUDA (the physics stays float32).
        starts: independent starts (seeds ``seed``, ``seed + 1``, …), each trained for
            ``start_steps`` in ``<out>/starts/seed<k>``; the one whose estimates best satisfy the
            equations of motion (:meth:`Trainer.physics_check`: lowest mean Kane term on fixed
            training windows — no labels) continues to ``steps``. 1 = a single run.
        start_steps: steps of each start (counted in ``steps``: the chosen start continues from it).
        weights_after_starts: loss weights that change from step ``start_steps`` on (the chosen
            start's continuation; in a single run the same steps), e.g. ``{foot_speed: 0}``:
            L_FS helps the starts find the gait's direction and phase, but the ZUPT foot speeds
            it compares with are biased low, and so was the estimated walking and running speed
            while it stayed on (docs/estimator_method.md, "No foot-speed term after the starts").
        joint_limits: the bounds term's ranges of motion: ``"paper"`` (hip and ankle ±60°, knee
            −60°…+0.1 rad) or ``"anatomical"`` (:meth:`~sspinn.model.body.JointLimits.anatomical`, wide
            enough for the knee flexion of running).
        compile: compile the decoding and the physics losses (forward and backward) with
            ``torch.compile`` (:func:`physics_terms`); the network stays eager. The generated
            equations of motion are thousands of small element-wise operations, so eager PyTorch
            spends the physics' time dispatching them; inductor fuses them into a few C++ loops
            (physics 3.6× faster, the demo-size step 1.51× on a 2-core CPU;
            ``benchmarks/speed/bench_sspinn.py``). The first step pays a one-off compilation (about a
            minute on a 2-core machine, without SIMD code generation: see :class:`PhysicsTerms`;
            a few seconds when inductor's cache in ``$TORCHINDUCTOR_CACHE_DIR`` already holds it). If compilation
            fails (no C++ compiler), training warns and continues eagerly. The numbers agree with
            the eager ones to float32 rounding, not bit for bit.
    """

    imus: str = "all"
    network: NetworkConfig = field(default_factory=NetworkConfig)
    weights: LossWeights = field(default_factory=LossWeights)
    imu_noise: IMUNoise | None = None
    finetune: bool = False
    finetune_last: int = 0
    learn_placement: bool = False
    placement_lr_factor: float = 1.0
    placement_angles: bool = True
    steps: int = 2000
    batch_size: int = 32
    window: int = 256
    lr: float = 1e-3
    lr_schedule: str = "constant"
    lr_final: float = 0.1
    input_noise: float = 0.25
    sensor_dropout: float = 0.0
    grad_clip: float = 1.0
    seed: int = 0
    device: str = "auto"
    threads: int = 0
    log_every: int = 20
    checkpoint_every: int = 200
    time_limit_s: float = 0.0
    amp: bool = True
    starts: int = 1
    start_steps: int = 750
    weights_after_starts: dict[str, float] = field(default_factory=dict)
    joint_limits: str = "paper"
    compile: bool = False

    def __post_init__(self) -> None:
        if isinstance(self.network, dict):
            self.network = NetworkConfig(**self.network)
        if isinstance(self.weights, dict):
            self.weights = LossWeights(**self.weights)
        if isinstance(self.imu_noise, dict):
            self.imu_noise = IMUNoise(**self.imu_noise)
        if not (math.isfinite(self.sensor_dropout) and 0 <= self.sensor_dropout < 1):
            raise ValueError(f"sensor_dropout must be in [0, 1), got {self.sensor_dropout}")
        if self.sensor_dropout > 0 and not self.network.sensor_presence:
            self.network = dataclasses.replace(self.network, sensor_presence=True)
        if self.imus not in IMU_CONFIGURATIONS:
            raise ValueError(f"unknown IMU configuration {self.imus!r}; choose one of {list(IMU_CONFIGURATIONS)}")
        for name in ("steps", "batch_size", "window", "log_every", "checkpoint_every", "starts", "start_steps"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.window < 8:
            raise ValueError(f"window must be at least 8 samples, got {self.window}")
        for name in ("lr", "grad_clip"):
            if not math.isfinite(getattr(self, name)) or getattr(self, name) <= 0:
                raise ValueError(f"{name} must be a finite number > 0, got {getattr(self, name)}")
        if self.lr_schedule not in ("constant", "cosine"):
            raise ValueError(f"lr_schedule must be 'constant' or 'cosine', got {self.lr_schedule!r}")
        if not 0 < self.lr_final <= 1:
            raise ValueError(f"lr_final must be in (0, 1], got {self.lr_final}")
        if not 0 <= self.finetune_last <= self.steps:
            raise ValueError(f"finetune_last must be in [0, steps={self.steps}], got {self.finetune_last}")
        if self.starts > 1 and self.start_steps >= self.steps:
            raise ValueError(f"start_steps ({self.start_steps}) must be fewer than steps ({self.steps}) with {self.starts} starts")
        JointLimits.named(self.joint_limits)  # raises with the choices for an unknown name
        known = LossWeights().as_dict()
        for name, value in self.weights_after_starts.items():
            if name not in known:
                raise ValueError(f"weights_after_starts: unknown loss term {name!r}; known: {sorted(known)}")
            if not math.isfinite(value) or value < 0:
                raise ValueError(f"weights_after_starts.{name} must be a finite number >= 0, got {value}")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")
        if not (math.isfinite(self.placement_lr_factor) and self.placement_lr_factor > 0):
            raise ValueError(f"placement_lr_factor must be a finite number > 0, got {self.placement_lr_factor}")
        if not math.isfinite(self.input_noise) or self.input_noise < 0:
            raise ValueError(f"input_noise must be a finite number >= 0, got {self.input_noise}")

    @classmethod
    def from_yaml(cls, path: str | Path, settings: list[str] | None = None, **overrides: Any) -> TrainConfig:
        """Load ``path``; ``overrides`` replace top-level options (None = keep), ``settings`` are
        ``"dotted.key=value"`` strings (YAML values), e.g. ``["weights.kane=0", "network.hidden=64"]``."""
        return load_config(cls, path, "train", overrides, settings or ())

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def weights_at(self, step: int) -> LossWeights:
        """The loss weights of step ``step`` (0-based): :attr:`weights`, changed by
        :attr:`weights_after_starts` from ``start_steps`` on, × the fine-tuning factors with
        :attr:`finetune` or in the last :attr:`finetune_last` steps."""
        weights = self.weights
        if self.weights_after_starts and step >= self.start_steps:
            weights = dataclasses.replace(weights, **self.weights_after_starts)
        return weights.finetune() if self.finetune or step >= self.steps - self.finetune_last else weights

    def lr_at(self, step: int) -> float:
        """The learning rate of step ``step`` (0-based) under :attr:`lr_schedule`."""
        if self.lr_schedule == "constant":
            return self.lr
        frac = min(step, self.steps) / self.steps
        return self.lr * (self.lr_final + (1 - self.lr_final) * 0.5 * (1 + math.cos(math.pi * frac)))


#: Self-supervised adaptation (``sspinn adapt``): optimiser steps and constant learning rate.
ADAPT_STEPS = 1000
ADAPT_LR = 5e-4


def adaptation_config(trained: dict[str, Any], source: str, settings: list[str] | None = None, **overrides: Any) -> TrainConfig:
    """The configuration that adapts a trained model to new, unlabeled recordings (a new
    subject's, or a held-out test split's; their labels are never read): the model's own
    training configuration (``trained``, as saved in its model file) with the loss weights it
    ended with (``weights_after_starts`` applied), one run of :data:`ADAPT_STEPS` at the constant
    :data:`ADAPT_LR` — small beside training's peak of 0.002, so the gait's phase, which the
    starts chose, stays — and **no input noise** (``input_noise`` 0). ``overrides`` (None =
    keep) and ``settings`` (``"a.b=value"``) apply last, as in :meth:`TrainConfig.from_yaml`;
    ``source`` names the model file in messages.

    Why: on subjects it has not seen the trained network fits their gyroscopes 1.5–5× worse
    than on its training subjects (docs/estimator_method.md, "Self-supervised adaptation"); the physics losses need no
    labels, so a thousand steps on the new recordings close most of that gap. Input noise
    regularises training for subjects not seen; adapting to the very recordings that will be
    estimated, it only shrinks the estimate towards its mean (regression dilution: joint-angle
    amplitudes 1–7 % small, strides short, speed biased low on five of six test recordings).
    """
    data = json.loads(json.dumps(trained))  # a deep copy of plain data
    data["weights"] = {**data.get("weights", {}), **data.get("weights_after_starts", {})}
    data.update(starts=1, weights_after_starts={}, steps=ADAPT_STEPS, lr=ADAPT_LR, lr_schedule="constant",
                finetune=False, finetune_last=0, input_noise=0.0)
    for key, value in overrides.items():
        if value is not None:
            set_option(data, key, value, source)
    for assignment in settings or ():
        apply_setting(data, assignment, source)
    return config_from_mapping(TrainConfig, data, source, what="train option")


def resolve_device(name: str) -> torch.device:
    if name == "auto":
        name = "cuda" if torch.cuda.is_available() else "cpu"
    if name == "cuda" and _world() > 1:
        return torch.device("cuda", int(os.environ.get("LOCAL_RANK", 0)))
    return torch.device(name)


def _world() -> int:
    return int(os.environ.get("WORLD_SIZE", 1))


def init_distributed(device: torch.device) -> tuple[int, int]:
    """(rank, world size); initialises torch.distributed when launched by ``torchrun`` (gloo on
    CPU, NCCL on CUDA). Each rank draws its own windows; gradients are averaged by DDP."""
    import torch.distributed as dist

    world = _world()
    if world <= 1:
        return 0, 1
    if not dist.is_initialized():
        dist.init_process_group(backend="nccl" if device.type == "cuda" else "gloo")
    return dist.get_rank(), dist.get_world_size()


# ------------------------------------------------------------------------------ data
@dataclass
class PreparedRecording:
    """A recording with the per-recording constants the network and losses need."""

    recording: Recording
    p: np.ndarray  # (41,) body parameters from height/mass (what the estimator assumes)
    placement: np.ndarray  # (21,) nominal IMU placement
    zupt_speed: np.ndarray | None  # (T, 2) or None
    out_scale: np.ndarray  # (n_outputs,) network output scales (see network.output_affine)
    out_offset: np.ndarray  # (n_outputs,)


def prepare(
    recordings: list[Recording], segments: tuple[str, ...], zupt: bool = True, grf: str = "contact_model"
) -> list[PreparedRecording]:
    """Select the IMUs, compute body parameters (Winter scaling), ZUPT foot speeds and the
    output scaling of a ``grf`` network (:attr:`~sspinn.estimator.network.NetworkConfig.grf`)."""
    out, restless = [], []
    for rec in recordings:
        sel = rec.select_imus(segments)
        speed, feet = foot_zupt_speeds(sel) if zupt else (None, [])
        restless += [f"{rec.name} ({foot})" for foot in feet]
        body = BodyParameters.from_anthropometry(rec.height, rec.mass)
        scale, offset = output_affine(rec.height, rec.mass, body.standing_hip_height, body.gravity, grf)
        out.append(PreparedRecording(sel, body.vector(), rec.placement.vector(), speed, scale, offset))
    if restless:  # one warning for the whole data set, not one per foot (running recordings have many)
        warnings.warn(
            f"the foot-speed loss L_FS is off for {len(restless)} foot IMU(s) in which the ZUPT detector found no "
            "stance (zero-velocity) phase — expected when running (the foot rolls), else check the units (rad/s, "
            "m/s²) or the thresholds zupt_gyro_threshold / zupt_acc_threshold of sspinn.estimator.zupt.SagittalZuptKalman: "
            f"{', '.join(restless)}",
            stacklevel=2,
        )
    return out


def foot_zupt_speeds(rec: Recording) -> tuple[np.ndarray | None, list[str]]:
    """(T, 2) horizontal foot speeds from a ZUPT Kalman filter on the foot IMUs (NaN for a
    missing foot, and for a foot without a detected stance phase), or None when no foot IMU is
    present; and the feet (``foot_r``, ``foot_l``) without a detected stance phase."""
    from sspinn.estimator.zupt import NoStanceError, foot_speed

    feet = [s for s in ("foot_r", "foot_l") if s in rec.segments]
    if not feet:
        return None, []
    speeds = np.full((rec.n_samples, 2), np.nan)
    restless = []
    for k, s in enumerate(("foot_r", "foot_l")):
        if s in rec.segments:
            sig = rec.imu[:, rec.segments.index(s)]
            try:
                speeds[:, k] = foot_speed(sig[:, :2], sig[:, 2], SAMPLE_RATE_HZ)
            except NoStanceError:  # e.g. running: the foot never rests long enough
                restless.append(s)
    return speeds, restless


class WindowSampler:
    """Random windows of ``window`` samples (with replacement) from prepared recordings, none
    overlapping a turn that ``sspinn import`` found (its ``turning_s``: a sagittal model does not
    describe a turn, so the losses there would teach a gait that did not happen)."""

    def __init__(self, data: list[PreparedRecording], window: int, rng: np.random.Generator) -> None:
        short = [d.recording.name for d in data if d.recording.n_samples < window]
        if short:
            raise ValueError(f"recordings shorter than the {window}-sample window: {short}")
        self.data, self.window, self.rng = data, window, rng
        self.starts: list[np.ndarray | None] = []  # the allowed starts where a recording has turns
        for d in data:
            turning = d.recording.provenance_mask("turning_s")
            if not turning.any():
                self.starts.append(None)
                continue
            inside = np.concatenate([[0], np.cumsum(turning)])
            n = d.recording.n_samples - window + 1
            allowed = np.flatnonzero(inside[window:window + n] - inside[:n] == 0)
            if not len(allowed):
                raise ValueError(f"{d.recording.name}: no {window}-sample window outside its turns {d.recording.provenance_spans('turning_s')}")
            self.starts.append(allowed)
        lengths = np.array([d.recording.n_samples - window + 1 if s is None else len(s) for d, s in zip(data, self.starts)], dtype=float)
        self.prob = lengths / lengths.sum()

    def sample(self, batch_size: int) -> tuple[list[int], list[int]]:
        which = self.rng.choice(len(self.data), size=batch_size, p=self.prob)
        starts = []
        for k in which:
            allowed = self.starts[k]
            if allowed is None:
                starts.append(int(self.rng.integers(0, self.data[k].recording.n_samples - self.window + 1)))
            else:
                starts.append(int(allowed[self.rng.integers(0, len(allowed))]))
        return [int(k) for k in which], starts


def make_batch(
    data: list[PreparedRecording], which: list[int], starts: list[int], window: int, segments: tuple[str, ...],
    imu_std: torch.Tensor, device: torch.device, dtype: torch.dtype = torch.float32,
) -> tuple[torch.Tensor, Batch]:
    """Network inputs (B, T, F) and the loss :class:`Batch` for the chosen windows.

    ``Batch.zupt_speed`` is None when no recording of ``data`` has ZUPT foot speeds, else a
    tensor for every batch (NaN, "unknown", in the windows of recordings without them): the
    batches of one training run then have one structure, so compiled physics
    (:class:`PhysicsTerms`) needs one graph, not one with and one without L_FS."""
    feats, imus, ps, places, heights, masses, zupts, scales, offsets = [], [], [], [], [], [], [], [], []
    for k, s in zip(which, starts):
        d = data[k]
        rec = d.recording
        sl = slice(s, s + window)
        feats.append(input_features(rec.imu[sl], rec.height, rec.mass, d.placement, segments))
        imus.append(rec.imu[sl])
        ps.append(d.p)
        places.append(d.placement)
        heights.append(rec.height)
        masses.append(rec.mass)
        zupts.append(d.zupt_speed[sl] if d.zupt_speed is not None else np.full((window, 2), np.nan))
        scales.append(d.out_scale)
        offsets.append(d.out_offset)

    def t(x: Any) -> torch.Tensor:
        return torch.as_tensor(np.asarray(x), dtype=dtype, device=device)

    zupt = t(zupts)
    batch = Batch(
        imu=t(imus), imu_std=imu_std.to(device=device, dtype=dtype), segments=segments, p=t(ps), height=t(heights),
        mass=t(masses), placement=t(places), dt=1.0 / SAMPLE_RATE_HZ,
        zupt_speed=zupt if any(d.zupt_speed is not None for d in data) else None,
        out_scale=t(scales), out_offset=t(offsets),
    )
    return t(feats), batch


# ------------------------------------------------------------------------------ trainer
def physics_terms(losses: PhysicsLosses, raw: torch.Tensor, batch: Batch) -> dict[str, torch.Tensor]:
    """Every loss term, unweighted, of the raw network outputs (B, T, n_outputs):
    :func:`~sspinn.estimator.network.decode` (for the losses' ground contact), then
    :meth:`PhysicsLosses.terms` — the part of a training step that :attr:`TrainConfig.compile`
    compiles (the weighting, :meth:`PhysicsLosses.weigh`, stays outside)."""
    return losses.terms(decode(raw, batch.out_scale, batch.out_offset, batch.dt, losses.grf), batch)


class CompileWarning(UserWarning):
    """``torch.compile`` of the physics failed; training continues with the eager physics."""


#: Threads of the compiled physics' forward pass. TorchDynamo guards a compiled graph on the
#: thread count, so with ``threads: 0`` (the cores not busy, re-measured) every change would
#: compile the physics again (a minute, cold); the forward physics is 2 ms of a 20-ms demo step.
PHYSICS_THREADS: Final = 1

#: inductor options of the physics' compilation: no SIMD code generation. The cold compilation
#: takes half as long (58 against 121–129 s, forward and backward, demo size, 2-core AMD EPYC) and
#: the step runs as fast (51.6–51.8 k against 42.6–49.8 k samples/s): the tensors are short
#: (batch × window elements), the kernels many (benchmarks/speed/bench_sspinn.py). A SIMD width that no
#: instruction set has (``cpp.simdlen: 1``), not ``cpp.vec_isa_ok: False``: inductor reads the
#: latter when it first probes the CPU and caches the answer for the process, so every later
#: compilation in that process (the environment's) would be built without SIMD flags, and fail on
#: vector code that its on-disk cache kept from an earlier process.
PHYSICS_COMPILE_OPTIONS: Final = {"cpp.simdlen": 1}


class PhysicsTerms:
    """:func:`physics_terms`, compiled with ``torch.compile`` when asked (see
    :attr:`TrainConfig.compile`; its forward pass on :data:`PHYSICS_THREADS` threads whatever the
    training's, so that one graph serves every thread count); falls back to eager, with a
    :class:`CompileWarning`, if the first compiled call fails."""

    _shared: Any = None  # one torch.compile wrapper per process: a second trainer (a start) reuses its graphs

    def __init__(self, compiled: bool) -> None:
        self.compiled = compiled
        if compiled:
            # create the backend namespace before any trace: a graph traced while it was first
            # created would guard on its absence and be compiled a second time on the next call
            ops_for(torch.zeros(()))
            if PhysicsTerms._shared is None:
                PhysicsTerms._shared = torch.compile(physics_terms, dynamic=False, options=dict(PHYSICS_COMPILE_OPTIONS))

    def __call__(
        self, losses: PhysicsLosses, raw: torch.Tensor, batch: Batch, weights: LossWeights | None = None
    ) -> dict[str, torch.Tensor]:
        """The terms weighted by ``weights`` (default ``losses.weights``) and their ``total``
        (:meth:`PhysicsLosses.weigh`)."""
        if self.compiled:
            threads = torch.get_num_threads()
            torch.set_num_threads(PHYSICS_THREADS)  # the thread count is part of a compiled graph's guards
            try:
                return losses.weigh(PhysicsTerms._shared(losses, raw, batch), weights)
            except Exception as exc:  # inductor needs a working C++ compiler; training must not die for speed
                message = f"torch.compile of the physics failed ({type(exc).__name__}: {str(exc)[:300]}); continuing eagerly"
                warnings.warn(message, CompileWarning, stacklevel=2)
                self.compiled = False
            finally:
                torch.set_num_threads(threads)
        return losses.weigh(physics_terms(losses, raw, batch), weights)


@contextlib.contextmanager
def denormals_flushed() -> Iterator[None]:
    """Inside, subnormal floats count as zero on the CPU (x86 FTZ/DAZ, ``torch.set_flush_denormal``);
    the calling thread's earlier setting is restored on the way out.

    Why: as training converges, Adam's second moments and the LSTM's small gradients fall below
    1.2e-38 (float32's smallest normal number), where x86 arithmetic takes a slow path: a demo
    model's steps ran at 18–21 steps/s after 12,000 steps against 26–28 with the flush, the losses
    equal to three digits (2-CPU Intel Xeon; ``docs/results/estimator.md``). Values that small are
    far below the resolution of anything a loss or an estimate holds. The flag belongs to a
    thread: torch's worker threads started inside inherit it (``pthread_create`` copies the
    floating-point environment) and keep it; the calling thread's is restored, so NumPy code run
    after training sees the setting it had before."""
    was_on = _denormals_flushed_now()
    torch.set_flush_denormal(True)
    try:
        yield
    finally:
        if not was_on:
            torch.set_flush_denormal(False)


def _denormals_flushed_now() -> bool:
    """Whether this thread flushes subnormals now: 1e-39 (a float32 subnormal) becomes 0."""
    return float(torch.tensor([1e-39], dtype=torch.float64).to(torch.float32)[0] * 2.0) == 0.0


class NonFiniteLossError(RuntimeError):
    """Raised when a loss becomes NaN/inf; the message names the windows of the batch."""


class Trainer:
    """Trains an :class:`SSPINNposeNet` on recordings, self-supervised: the machinery behind
    :meth:`SSPINNpose.fit <sspinn.estimator.sspinnpose.SSPINNpose.fit>`, ``adapt`` and ``finetune``
    (the one way in for users and the project's own code; not a public name).

    Args:
        config: the run's configuration.
        out: run folder (checkpoints ``checkpoint.pt``/``model.pt``, ``config.yaml``, TensorBoard).
    """

    def __init__(self, config: TrainConfig, out: str | Path) -> None:
        self.config = config
        self.out = Path(out)
        self.segments = IMU_CONFIGURATIONS[config.imus]
        self.device = resolve_device(config.device)
        self.step = 0
        #: "steps" (the step count was reached) or "time_limit" (the safety net fired) after :meth:`fit`.
        self.stopped_by = "steps"
        self.model: SSPINNposeNet | None = None
        self.history: list[dict[str, float]] = []
        #: the trivial predictors of the training data stored with the model: fitted on the
        #: training recordings' labels in a training from scratch, the starting model's with
        #: ``init_from`` (fine-tuning and adaptation recordings are often the ones evaluated
        #: next), the checkpoint's on resume; None without labels
        self.baselines: TrivialPredictor | None = None

    # -------------------------------------------------------------- setup
    def _setup(self, train: list[Recording]) -> None:
        cfg = self.config
        self.rank, self.world = init_distributed(self.device)
        random.seed(cfg.seed)
        np.random.seed(cfg.seed)
        torch.manual_seed(cfg.seed)  # identical initial weights on every rank
        self.threads = ThreadShare(cfg.threads, every=max(cfg.checkpoint_every, 1000))
        self.rng = np.random.default_rng([cfg.seed, self.rank])  # but different windows
        self.data = prepare(train, self.segments, grf=cfg.network.grf)
        #: names of the recordings whose IMU signals this model's training saw (with init_from,
        #: the starting model's too)
        self.trained_on: tuple[str, ...] = tuple(d.recording.name for d in self.data)
        self.sampler = WindowSampler(self.data, cfg.window, self.rng)
        all_imu = np.concatenate([d.recording.imu for d in self.data])  # (N, n_imu, 3)
        self.imu_std = torch.as_tensor(all_imu.std(axis=0).clip(min=1e-3), dtype=torch.float32)
        if cfg.imu_noise is not None:
            self.imu_std = cfg.imu_noise.scales(self.imu_std)
        feats = np.concatenate([
            input_features(d.recording.imu, d.recording.height, d.recording.mass, d.placement, self.segments)
            for d in self.data
        ])
        self.model = SSPINNposeNet(feats.shape[1], cfg.network).to(self.device)
        self.model.set_normalisation(torch.as_tensor(feats.mean(0), dtype=torch.float32),
                                     torch.as_tensor(feats.std(0), dtype=torch.float32), feature_std_floor(self.segments),
                                     constants=feats.shape[1] - 3 * len(self.segments))
        self.noise_std = torch.as_tensor(feats.std(0), dtype=torch.float32, device=self.device)
        self.noise_std[3 * len(self.segments):] = 0.0  # no noise on the constants
        # learnable IMU placement per recording (the paper's placement optimisation)
        self.placement = torch.nn.Parameter(torch.as_tensor(np.stack([d.placement for d in self.data]), dtype=torch.float32, device=self.device))
        params: list[Any] = list(self.model.parameters())
        if cfg.learn_placement and cfg.placement_lr_factor == 1.0:
            params.append(self.placement)
        elif cfg.learn_placement:  # a group of its own, lr_scale × the schedule's lr (_fit)
            params = [{"params": params}, {"params": [self.placement], "lr_scale": cfg.placement_lr_factor}]
        if cfg.learn_placement and not cfg.placement_angles:  # positions only: no gradient reaches the angles
            keep = torch.ones_like(self.placement)
            keep[:, 2::3] = 0.0
            self.placement.register_hook(lambda grad: grad * keep)
        self.optimizer = torch.optim.Adam(params, lr=cfg.lr)
        limits = JointLimits.named(cfg.joint_limits)
        self.losses = PhysicsLosses(cfg.weights, limits=limits, grf=cfg.network.grf)  # weighted per step: cfg.weights_at
        self.physics = PhysicsTerms(cfg.compile)
        self.net: torch.nn.Module = self.model
        if self.world > 1:
            from torch.nn.parallel import DistributedDataParallel

            self.net = DistributedDataParallel(self.model, device_ids=[self.device.index] if self.device.type == "cuda" else None)

    # -------------------------------------------------------------- checkpoints
    def save_checkpoint(self, path: Path | None = None, rng: dict[str, Any] | None = None) -> Path:
        """Write the whole training state (atomically, see :mod:`sspinn.torch_files`); ``rng``
        replaces the current random-generator states (the states at the last step boundary when
        a step was interrupted)."""
        path = path or self.out / "checkpoint.pt"
        assert self.model is not None
        state = {
            "step": self.step,
            "config": self.config.to_dict(),
            "segments": self.segments,
            "model": self.model.state_dict(),
            "hyperparameters": self.model.hyperparameters(),
            "optimizer": self.optimizer.state_dict(),
            "placement": self.placement.detach().cpu(),
            "recordings": [d.recording.name for d in self.data],
            "trained_on": self.trained_on,
            "baselines": baselines_entry(self.baselines),
            "imu_std": self.imu_std,
            "rng": rng or self._rng_state(),
            "history": self.history,
            "world_size": self.world,
        }
        return save_torch_file(path, CHECKPOINT, state)

    def _rng_state(self) -> dict[str, Any]:
        return {"numpy": self.rng.bit_generator.state, "torch": torch.get_rng_state()}

    def _draw_presence(self, batch_size: int) -> torch.Tensor:
        """(B, n_imus) presence flags of one batch (:attr:`TrainConfig.sensor_dropout`): each IMU
        missing with that probability, independently; a window that lost all keeps one at random."""
        present = self.rng.random((batch_size, len(self.segments))) >= self.config.sensor_dropout
        for row in np.flatnonzero(~present.any(axis=1)):
            present[row, self.rng.integers(len(self.segments))] = True
        return torch.as_tensor(present, dtype=torch.float32, device=self.device)

    def _check_segments(self, segments: tuple[str, ...], path: Path) -> None:
        if tuple(segments) != self.segments:
            raise ModelFileError(
                f"{path}: trained on IMUs {list(segments)}, this run uses {list(self.segments)}; "
                "use the same imus setting or another run folder"
            )

    def start_from(self, source: StoredModel) -> None:
        """Copy a trained model's weights into a set-up trainer (fine-tuning or adapting it to new
        recordings); its ``trained_on`` names are kept. Raises :class:`ModelFileError` naming the
        model's file and what does not fit."""
        assert self.model is not None
        self._check_segments(source.segments, source.path)
        state = {"model": source.network.state_dict(), "hyperparameters": source.network.hyperparameters(), "segments": source.segments}
        load_weights(self.model, state, source.path)
        check_finite_weights(source.path, self.model.state_dict(), "the model is damaged or its training diverged")
        self.trained_on = tuple(dict.fromkeys((source.trained_on or ()) + self.trained_on))
        self.baselines = source.baselines

    def load_checkpoint(self, path: Path) -> None:
        """Restore a checkpoint (the whole training state) into a set-up trainer. Raises
        :class:`ModelFileError` naming the file and what does not fit."""
        path = Path(path)
        hint = "delete it (or choose a new --out) to start afresh, or resume from an intact copy"
        state = load_torch_file(path, (CHECKPOINT,), CHECKPOINT_ENTRIES, hint, self.device)
        self._check_segments(tuple(state["segments"]), path)
        assert self.model is not None
        load_weights(self.model, state, path)
        check_finite_weights(path, self.model.state_dict(), "the model is damaged or its training diverged")
        if state["recordings"] != [d.recording.name for d in self.data]:
            raise ModelFileError(f"{path}: checkpoint was trained on other recordings; resume needs the same --data")
        self.trained_on = tuple(state.get("trained_on", self.trained_on))
        if "baselines" in state:
            self.baselines = read_baselines(state, path)
        elif set(self.trained_on) == {d.recording.name for d in self.data}:  # older checkpoint of a training from scratch
            self.baselines = training_predictor([d.recording for d in self.data])
        try:
            self.optimizer.load_state_dict(state["optimizer"])
            with torch.no_grad():
                self.placement.copy_(state["placement"].to(self.device))
            self.rng.bit_generator.state = state["rng"]["numpy"]
            torch.set_rng_state(state["rng"]["torch"].cpu())
        except (ValueError, RuntimeError, KeyError, TypeError) as exc:
            raise ModelFileError(f"{path}: the checkpoint's optimizer or random state does not fit this run ({exc}); "
                                 "use the same settings as the interrupted run, or another run folder") from None
        self.step = int(state["step"])
        self.history = list(state.get("history", []))

    # -------------------------------------------------------------- training
    def fit(self, train: list[Recording], resume: bool = False, init_from: str | Path | StoredModel | None = None) -> SSPINNposeNet:
        """Train for ``config.steps`` steps (continuing from ``checkpoint.pt`` with ``resume``,
        or starting from a trained model's weights with ``init_from``: a loaded
        :class:`StoredModel` or the path of its file). Returns the model.

        The run folder is owned by this run while it trains (:class:`RunLock`): a second run
        into the same folder stops with an error naming this one. Ctrl-C finishes the current
        step, saves ``checkpoint.pt`` and raises :class:`KeyboardInterrupt`; ``resume`` then
        continues exactly as if uninterrupted."""
        with denormals_flushed():
            if int(os.environ.get("RANK", "0")) != 0:  # under torchrun only rank 0 owns the folder
                return self._fit(train, resume, init_from)
            with RunLock(self.out):
                return self._fit(train, resume, init_from)

    def _fit(self, train: list[Recording], resume: bool, init_from: str | Path | StoredModel | None) -> SSPINNposeNet:
        from tqdm.auto import tqdm

        cfg = self.config
        self.out.mkdir(parents=True, exist_ok=True)
        self._setup(train)
        ckpt = self.out / "checkpoint.pt"
        if resume:
            if not ckpt.exists():
                raise FileNotFoundError(f"{ckpt}: no checkpoint to resume from (--resume); start without it, or use --auto-resume")
            self.load_checkpoint(ckpt)
        elif init_from is not None:
            self.start_from(init_from if isinstance(init_from, StoredModel) else load_model(init_from, self.device))
        elif cfg.starts > 1:
            self.load_checkpoint(self._best_start(train))
        else:
            self.baselines = training_predictor(train)
        lead = self.rank == 0  # only rank 0 writes files and shows progress
        if lead:
            atomic_write_text(self.out / "config.yaml", yaml.safe_dump({"train": cfg.to_dict()}, sort_keys=False))
        writer = _tensorboard(self.out / "tensorboard") if lead else None
        assert self.model is not None
        self.model.train()
        start_time = time.perf_counter()
        self.stopped_by = "steps"
        bar = tqdm(total=cfg.steps, initial=self.step, desc="training", unit="step", dynamic_ncols=True, disable=not lead)
        autocast = (
            torch.autocast("cuda", dtype=torch.bfloat16) if cfg.amp and self.device.type == "cuda" else contextlib.nullcontext()
        )
        interrupt = DeferredInterrupt().install()
        boundary_rng, mid_step = self._rng_state(), False
        try:
            while self.step < cfg.steps:
                boundary_rng, mid_step = self._rng_state(), True  # the state a resume must start from
                for group in self.optimizer.param_groups:
                    group["lr"] = cfg.lr_at(self.step) * group.get("lr_scale", 1.0)
                which, starts = self.sampler.sample(cfg.batch_size)
                x, batch = make_batch(self.data, which, starts, cfg.window, self.segments, self.imu_std, self.device)
                batch.placement = self.placement[which]
                x = x + torch.randn_like(x) * cfg.input_noise * self.noise_std
                present = self._draw_presence(len(which)) if cfg.sensor_dropout > 0 else None
                with autocast:
                    raw, _ = self.net(x, present=present)
                terms = self.physics(self.losses, raw.float(), batch, cfg.weights_at(self.step))
                loss = terms["total"]
                if not torch.isfinite(loss):
                    bad = [f"{self.data[k].recording.name}[{s}:{s + cfg.window}]" for k, s in zip(which, starts)]
                    self.save_checkpoint(self.out / f"checkpoint_before_nan_rank{self.rank}.pt")
                    raise NonFiniteLossError(
                        f"step {self.step} (rank {self.rank}): loss is {loss.item()} "
                        f"({', '.join(k for k, v in terms.items() if k != 'grf' and not torch.isfinite(v).all())} non-finite) "
                        f"on windows {bad}; last good state saved to checkpoint_before_nan_rank{self.rank}.pt"
                    )
                self.optimizer.zero_grad(set_to_none=True)
                loss.backward()
                if self.world > 1 and cfg.learn_placement and self.placement.grad is not None:
                    import torch.distributed as dist

                    dist.all_reduce(self.placement.grad)
                    self.placement.grad /= self.world
                torch.nn.utils.clip_grad_norm_(self.model.parameters(), cfg.grad_clip)
                self.optimizer.step()
                self.step += 1
                mid_step = False
                bar.update(1)
                if self.step % cfg.log_every == 0 or self.step == cfg.steps:
                    record = {k: float(v.detach()) for k, v in terms.items() if k != "grf"}
                    record["step"] = self.step
                    record["wall_s"] = time.perf_counter() - start_time
                    self.history.append(record)
                    bar.set_postfix(loss=f"{record['total']:.3g}")
                    if writer is not None:
                        for k, v in record.items():
                            if k not in ("step",):
                                writer.add_scalar(f"loss/{k}" if k != "wall_s" else "time/wall_s", v, self.step)
                if self.step % cfg.checkpoint_every == 0 and lead:
                    self.save_checkpoint()
                self.threads.update(self.step)
                if self._agree(interrupt.requested):
                    raise KeyboardInterrupt
                if cfg.time_limit_s and self._agree(time.perf_counter() - start_time > cfg.time_limit_s):
                    self.stopped_by = "time_limit"
                    message = (
                        f"WARNING: the safety time limit of {cfg.time_limit_s:.0f} s stopped training at step "
                        f"{self.step} of {cfg.steps}: this result depends on the machine's speed and load and is "
                        f"not reproducible; continue with --resume (or raise time_limit_s)"
                    )
                    bar.write(message)
                    warnings.warn(message, TimeLimitWarning, stacklevel=2)
                    break
        except KeyboardInterrupt:
            if lead:
                bar.write(f"interrupted at step {self.step}: saving {ckpt} (continue with --resume)")
                # a step cut short changed nothing but the random state: save the one before it
                self.save_checkpoint(rng=boundary_rng if mid_step else None)
            raise
        finally:
            interrupt.restore()
            bar.close()
            if writer is not None:
                writer.close()
        if lead:
            self.save_checkpoint()
            save_model(self.model, self.out / "model.pt", self.segments, self.config.to_dict(), self.imu_std, self.trained_on,
                       self.baselines)
            summary = {
                "steps": self.step,
                "steps_planned": cfg.steps,
                "stopped_by": self.stopped_by,
                "wall_s_this_run": round(time.perf_counter() - start_time, 1),
            }
            atomic_write_text(self.out / "training_summary.json", json.dumps(summary, indent=2))
        return self.model

    def _best_start(self, train: list[Recording]) -> Path:
        """Train ``config.starts`` short runs (or resume them) and return the checkpoint of the
        most physically consistent one; ``<out>/starts.json`` records every start's check.

        Why: on running, about one seed in three converged to a solution whose stance sits on the
        wrong foot (the loss of that solution is higher, but gradient descent does not leave it);
        the Kane term separates the two within a few hundred steps (docs/estimator_method.md)."""
        cfg = self.config
        if self.world > 1:
            raise ValueError("starts > 1 is not supported under torchrun; train the starts on one process")
        checks = {}
        for k in range(cfg.starts):
            seed = cfg.seed + k
            folder = self.out / "starts" / f"seed{seed}"
            # a start runs at the constant peak rate; the schedule (over ``steps``) is the chosen start's continuation's
            sub = Trainer(dataclasses.replace(cfg, seed=seed, steps=cfg.start_steps, starts=1, finetune_last=0, lr_schedule="constant"), folder)
            sub.fit(train, resume=(folder / "checkpoint.pt").exists())
            checks[seed] = sub.physics_check()
        best = min(checks, key=lambda seed: checks[seed]["kane"])
        atomic_write_text(self.out / "starts.json", json.dumps(
            {"chosen_seed": best, "criterion": "lowest mean Kane term (unweighted) on fixed training windows",
             "start_steps": cfg.start_steps, "checks": {str(k): v for k, v in checks.items()}}, indent=2))
        print(f"starts: seed {best} chosen of {sorted(checks)} (Kane term "
              + ", ".join(f"{checks[k]['kane']:.3g}" for k in sorted(checks)) + ")")
        return self.out / "starts" / f"seed{best}" / "checkpoint.pt"

    @torch.no_grad()
    def physics_check(self, windows_per_recording: int = 8) -> dict[str, float]:
        """Each loss term, unweighted, averaged over fixed, evenly spaced windows of the training
        recordings (network in eval mode, no input noise): a label-free measure of the estimate."""
        assert self.model is not None
        cfg = self.config
        unit = PhysicsLosses(LossWeights.unit(), limits=JointLimits.named(cfg.joint_limits), grf=cfg.network.grf)
        which, starts = [], []
        for k, d in enumerate(self.data):
            for s in np.linspace(0, d.recording.n_samples - cfg.window, windows_per_recording).astype(int):
                which.append(k)
                starts.append(int(s))
        self.model.eval()
        sums: dict[str, float] = {}
        try:
            for i in range(0, len(which), 64):  # chunks bound the memory for large datasets
                w, st = which[i:i + 64], starts[i:i + 64]
                x, batch = make_batch(self.data, w, st, cfg.window, self.segments, self.imu_std, self.device)
                batch.placement = self.placement[w]
                raw, _ = self.model(x)
                terms = physics_terms(unit, raw.float(), batch)
                for k, v in terms.items():
                    if k not in ("grf", "total"):
                        sums[k] = sums.get(k, 0.0) + float(v) * len(w)
        finally:
            self.model.train()
        return {k: v / len(which) for k, v in sums.items()}

    def _agree(self, flag: bool) -> bool:
        """True on every rank if it is true on any (so all ranks stop at the same step)."""
        if self.world <= 1:
            return flag
        import torch.distributed as dist

        t = torch.tensor([float(flag)], device=self.device)
        dist.all_reduce(t, op=dist.ReduceOp.MAX)
        return bool(t.item())


class TimeLimitWarning(UserWarning):
    """Training was stopped by its safety time limit, not by its step count: the result depends
    on the machine's speed and load (see ``training_summary.json``)."""


def _tensorboard(folder: Path):
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:  # tensorboard is a dependency; keep training alive without it
        return None
    return SummaryWriter(str(folder))


#: Entries of a training checkpoint (:meth:`Trainer.save_checkpoint`): a model file's and the training state.
CHECKPOINT_ENTRIES: tuple[str, ...] = (*MODEL_ENTRIES, "step", "optimizer", "placement", "recordings", "rng")

"""Train an SB3 agent (PPO, SAC or TD3) on ``sspinn/SagittalWalker-v0``, top to bottom.

    python -m agents train --algo ppo --config configs/agents/ppo.yaml --out runs/ppo
    python -m agents train --config configs/agents/ppo.yaml --out runs/ppo --resume

:func:`train` reads like a CleanRL script: seed → vectorised environments → VecNormalize →
model (new, or the latest checkpoint when resuming) → callbacks (checkpoints, evaluations) →
``learn`` → save. The files it writes are listed in :mod:`agents.checkpoints`.
"""

from __future__ import annotations

import csv
import math
import time
from pathlib import Path
from typing import Any

import numba
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.logger import configure as configure_logger
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv, VecNormalize

from agents.builders import WALKING_BELOW_M_S, algorithm_class, algorithm_kwargs, env_kwargs, make_env, policy_kwargs
from agents.checkpoints import (
    CHECKPOINT_DIR,
    CHECKPOINT_PREFIX,
    EVAL_COLUMNS,
    LoadedAgent,
    append_csv_row,
    checkpoint_steps,
    latest_checkpoint,
    load_algorithm,
    load_statistics,
    open_run_folder,
    replay_buffer_path,
    restore_replay_buffer,
    save_checkpoint,
    vecnormalize_path,
)
from agents.config import DIFF_ALGORITHMS, AgentConfig
from agents.gait_prior import GaitPrior, GaitPriorReward, load_prior
from agents.rollout import run_episode, summarize
from agents.vec_env import PerEnvVecMonitor, WalkerVecEnv
from sspinn.data.gait_metrics import winter_or_none
from sspinn.interrupt import DeferredInterrupt
from sspinn.run_folder import RunLock

#: What a run leaves in its folder (:mod:`agents.checkpoints`), besides its config: a folder
#: holding any of them holds a run, which only ``--resume`` continues and ``--overwrite`` replaces.
RUN_OUTPUTS: tuple[str, ...] = (
    "final_model.zip", "final_vecnormalize.pkl", "best_model.zip", "best_vecnormalize.pkl", "evaluations.csv",
    CHECKPOINT_DIR, "monitor", "tb",
)

#: Info fields of the environment written to the Monitor CSV of every training episode.
MONITOR_INFO_KEYS: tuple[str, ...] = ("distance", "cost_of_transport")


def make_training_envs(
    config: AgentConfig, run_dir: Path, seed: int, prior: GaitPrior | None, append_monitor: bool = False
) -> VecEnv:
    """``n_envs`` seeded environments (seeds ``seed``, ``seed + 1``, ...) with one Monitor CSV log
    per environment (``<run>/monitor/<i>.monitor.csv``): the native vector environment
    (``env.vec_env: native``) or SB3's ``DummyVecEnv``/``SubprocVecEnv`` of single environments;
    with ``prior`` (:func:`agents.gait_prior.load_prior` of the configuration), its training
    reward outside the Monitor logs (which keep the environment's own episode returns) and its
    reference starts."""
    starts = reference_starts(config, prior)
    if config.env.vec_env == "native":
        if config.env.threads is not None:
            numba.set_num_threads(min(config.env.threads, numba.config.NUMBA_NUM_THREADS))
        venv: VecEnv = WalkerVecEnv(config.env.n_envs, **env_kwargs(config, **starts))
        venv.seed(seed)
        venv = PerEnvVecMonitor(venv, run_dir / "monitor", MONITOR_INFO_KEYS, append=append_monitor)
    else:
        vec_cls = SubprocVecEnv if config.env.vec_env == "subproc" else DummyVecEnv
        venv = make_vec_env(
            lambda: make_env(config, **starts),
            n_envs=config.env.n_envs,
            seed=seed,
            vec_env_cls=vec_cls,
            monitor_dir=str(run_dir / "monitor"),
            monitor_kwargs={"info_keywords": MONITOR_INFO_KEYS, "override_existing": not append_monitor},
        )
    return venv if prior is None else GaitPriorReward(venv, prior)


def reference_starts(config: AgentConfig, prior: GaitPrior | None) -> dict[str, Any]:
    """Environment arguments that start ``config.prior.start_share`` of the training episodes at a
    random sample of the prior's reference stride (none without a prior or share); evaluations
    always start standing."""
    if prior is None or config.prior.start_share == 0:
        return {}
    return {"reset_states": prior.stride_states(), "reset_state_share": config.prior.start_share}


class PeriodicCheckpoint(BaseCallback):
    """Every ``save_freq`` calls (one call steps all ``n_envs`` environments): the model, its
    VecNormalize statistics and (``replay_buffer``) its replay buffer under
    ``<run>/checkpoints/model_<steps>_steps.*``, written by :func:`agents.checkpoints.save_checkpoint`
    (atomic files, the ``.zip`` last). SB3's ``CheckpointCallback`` writes the same names but
    straight into the final files, so a crash mid-write would leave a truncated checkpoint that
    ``--resume`` picks as the latest.

    With ``interrupt`` (:class:`sspinn.interrupt.DeferredInterrupt`), a Ctrl-C also saves a
    checkpoint, at the end of the vector step it arrived in, and stops training (``learn`` returns;
    :attr:`interrupted_at` is the checkpoint written), so that nothing since the last periodic
    checkpoint is lost and ``--resume`` continues from there."""

    def __init__(self, folder: Path, save_freq: int, vec_normalize: VecNormalize | None, replay_buffer: bool,
                 interrupt: DeferredInterrupt | None = None) -> None:
        super().__init__()
        self.folder = folder
        self.save_freq = save_freq
        self.vec_normalize = vec_normalize
        self.replay_buffer = replay_buffer
        self.interrupt = interrupt
        self.interrupted_at: Path | None = None

    def _save(self) -> Path:
        path = self.folder / f"{CHECKPOINT_PREFIX}_{self.num_timesteps}_steps.zip"
        save_checkpoint(self.model, path, self.vec_normalize, self.replay_buffer)
        return path

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            self._save()
        if self.interrupt is not None and self.interrupt.requested:
            self.interrupted_at = self._save()
            return False
        return True


class WalkerEvalCallback(BaseCallback):
    """Every ``eval_freq`` timesteps: deterministic episodes on fixed seeds at the evaluation
    target speed; logs distance, speed, speed error, cost of transport, falls and the gait metrics
    (:func:`sspinn.data.gait_metrics.gait_metrics`: asymmetries, foot sliding, impact peak, angle RMSD to
    Winter's walking when ``$SSPINN_SHARED_DATA`` holds it and the target is a walking speed) to
    TensorBoard ``eval/*`` and ``evaluations.csv``, and saves the best model (mean return) with
    its VecNormalize statistics."""

    def __init__(
        self, config: AgentConfig, run_dir: Path, vec_normalize: VecNormalize | None, prior: GaitPrior | None = None
    ) -> None:
        super().__init__(verbose=config.logging.verbose)
        self.config = config
        self.run_dir = run_dir
        self.vec_normalize = vec_normalize
        self.eval_env = make_env(config)
        self.reference = winter_or_none() if config.env.target_speed < WALKING_BELOW_M_S else None
        self.prior = prior if config.prior.clock else None  # the policy's clock (the training prior)
        self.csv_path = run_dir / "evaluations.csv"
        self.best_return = -math.inf
        self.next_eval = 0
        self.start = time.perf_counter()
        self.start_steps = 0
        if self.csv_path.is_file():  # resuming: keep the best score so far
            with self.csv_path.open() as fh:
                returns = [float(row["mean_return"]) for row in csv.DictReader(fh)]
            self.best_return = max(returns, default=-math.inf)

    def _on_training_start(self) -> None:
        freq = self.config.logging.eval_freq
        self.next_eval = (self.num_timesteps // freq + 1) * freq
        self.start = time.perf_counter()
        self.start_steps = self.num_timesteps

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next_eval:
            self.next_eval += self.config.logging.eval_freq
            self.evaluate()
        return True

    def current_policy(self) -> LoadedAgent:
        """The model being trained with a frozen copy of the current observation statistics."""
        agent = LoadedAgent(model=self.model, config=self.config, prior=self.prior)
        if self.vec_normalize is not None and self.vec_normalize.norm_obs:
            agent.obs_mean = self.vec_normalize.obs_rms.mean.copy()
            agent.obs_var = self.vec_normalize.obs_rms.var.copy()
            agent.clip_obs = self.vec_normalize.clip_obs
            agent.epsilon = self.vec_normalize.epsilon
        return agent

    def evaluate(self) -> dict[str, Any]:
        """Run the evaluation episodes now; log, append to the CSV, save if best."""
        lg = self.config.logging
        policy = self.current_policy()
        results = [
            run_episode(policy, self.eval_env, lg.eval_seed + i, self.config.env.target_speed, reference=self.reference)
            for i in range(lg.eval_episodes)
        ]
        summary = summarize(results)
        wall = time.perf_counter() - self.start
        row = {"timesteps": self.num_timesteps, "wall_s": round(wall, 1), **summary}
        for key, value in summary.items():
            if value is not None:
                self.logger.record(f"eval/{key}", value)
        self.logger.record("eval/steps_per_s", (self.num_timesteps - self.start_steps) / max(wall, 1e-9))
        append_csv_row(self.csv_path, row, EVAL_COLUMNS)  # a resumed run keeps its file's columns
        if summary["mean_return"] > self.best_return:
            self.best_return = summary["mean_return"]
            save_checkpoint(self.model, self.run_dir / "best_model.zip", self.vec_normalize)
        print(
            f"[eval] {self.num_timesteps:>10d} steps  {wall:7.0f} s  return {summary['mean_return']:7.1f}  "
            f"distance {summary['mean_distance_m']:5.2f} m (min {summary['min_distance_m']:5.2f})  "
            f"speed {summary['mean_speed_m_s']:4.2f} m/s  falls {summary['falls']}/{summary['episodes']}  "
            f"asym. step time {_fmt(summary['mean_step_time_asymmetry'])} % contact {_fmt(summary['mean_contact_asymmetry'])} %  slide/step "
            f"{_fmt(summary['mean_foot_slide_per_step_cm'])} cm  impact {_fmt(summary['mean_peak_impact_bw'])} BW",
            flush=True,
        )
        return row

    def _on_training_end(self) -> None:
        self.eval_env.close()


def _fmt(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.1f}"


def train(config: AgentConfig, out: str | Path, resume: bool = False, overwrite: bool = False) -> BaseAlgorithm:
    """Train according to ``config`` into the run directory ``out`` and return the model.

    With ``resume``, the latest checkpoint in ``<out>/checkpoints`` and its VecNormalize statistics
    are loaded and training continues up to ``total_timesteps`` (``reset_num_timesteps=False``, so
    step counts, schedules and TensorBoard curves carry on). Without it, ``out`` must not hold a
    run already (any of :data:`RUN_OUTPUTS`: a :class:`FileExistsError` names them) unless
    ``overwrite``, which deletes them first. The run directory is owned by this run while it trains
    (:class:`sspinn.run_folder.RunLock`): a second run into it stops with an error naming this one.
    """
    if resume and overwrite:
        raise ValueError("--resume continues the run in --out and --overwrite replaces it: give one of them")

    with RunLock(out):
        if config.algo in DIFF_ALGORITHMS:  # learned through the differentiable simulator (agents.diff)
            from agents.diff.train import train_diff

            return train_diff(config, Path(out), resume, overwrite)  # type: ignore[return-value]
        return _train(config, Path(out), resume, overwrite)


def _train(config: AgentConfig, out: Path, resume: bool, overwrite: bool) -> BaseAlgorithm:
    # 1. run directory, threads, seeds (a resumed run continues from seed + steps done, so that its
    #    environments do not replay the initial states of the first part)
    run_dir = Path(out)
    checkpoint = latest_checkpoint(run_dir)
    open_run_folder(config, run_dir, checkpoint, resume, overwrite, RUN_OUTPUTS)
    seed = (config.seed + (checkpoint_steps(checkpoint) if resume else 0)) % 2**32  # numpy takes 32-bit seeds
    set_random_seed(seed)
    algo_cls = algorithm_class(config)
    tensorboard_log = str(run_dir / "tb") if config.logging.tensorboard else None

    # 2. vectorised environments, observation/reward normalisation (statistics restored on resume)
    prior = load_prior(config)  # read once: the training reward and the evaluated policy's clock
    venv: VecEnv = make_training_envs(config, run_dir, seed, prior, append_monitor=resume)
    norm = config.normalize
    vec_normalize: VecNormalize | None = None
    if resume and (norm.obs or norm.reward):
        stats = vecnormalize_path(checkpoint)
        if not stats.is_file():
            raise FileNotFoundError(f"--resume: {stats} (VecNormalize statistics of {checkpoint.name}) is missing")
        vec_normalize = load_statistics(stats)  # runs no code from the file (agents.checkpoints)
        vec_normalize.set_venv(venv)
        vec_normalize.training = True
    elif norm.obs or norm.reward:
        vec_normalize = VecNormalize(
            venv, norm_obs=norm.obs, norm_reward=norm.reward, clip_obs=norm.clip_obs,
            clip_reward=norm.clip_reward, gamma=config.gamma,
        )
    if vec_normalize is not None:
        venv = vec_normalize

    # 3. the model: new, or the latest checkpoint (with its replay buffer, if one was kept)
    if resume:
        model = load_algorithm(checkpoint, config, env=venv, device="cpu", tensorboard_log=tensorboard_log)
        buffer = replay_buffer_path(checkpoint)
        if hasattr(model, "replay_buffer") and buffer.is_file():
            restore_replay_buffer(model, buffer)
        print(f"resuming from {checkpoint} at {model.num_timesteps} timesteps", flush=True)
    else:
        model = algo_cls(
            "MlpPolicy", venv, seed=seed, device="cpu", tensorboard_log=tensorboard_log,
            policy_kwargs=policy_kwargs(config), verbose=config.logging.verbose,
            **algorithm_kwargs(config, venv.action_space.shape[0]),
        )

    if tensorboard_log is None:  # else SB3 makes an empty SB3-<time> folder in the system's temp dir per run
        model.set_logger(configure_logger(str(run_dir), ["stdout"] if config.logging.verbose else []))

    steps_before = model.num_timesteps
    print(f"training {config.algo.upper()} on {config.env.id} ({config.env.n_envs} envs, {config.env.vec_env}) "
          f"from step {steps_before:,} to {config.total_timesteps:,} → {run_dir}", flush=True)
    started = time.perf_counter()

    # 4. callbacks: periodic checkpoints (+ VecNormalize, replay buffer) and evaluations
    interrupt = DeferredInterrupt("finishing the current vector step, then saving a checkpoint (Ctrl-C again to stop at once)")
    checkpoints = PeriodicCheckpoint(run_dir / CHECKPOINT_DIR, max(config.logging.checkpoint_freq // config.env.n_envs, 1),
                                     vec_normalize, config.logging.keep_replay_buffer, interrupt)
    callbacks: list[BaseCallback] = [checkpoints]
    if config.logging.eval_freq > 0:
        callbacks.append(WalkerEvalCallback(config, run_dir, vec_normalize, prior))

    # 5. learn, then save the final model and statistics
    #    (a first Ctrl-C saves a checkpoint at the end of the vector step and stops: continue with --resume)
    interrupt.install()
    try:
        model.learn(
            total_timesteps=config.total_timesteps if not resume else max(config.total_timesteps - model.num_timesteps, 0),
            callback=callbacks,
            tb_log_name="run",
            reset_num_timesteps=not resume,
        )
    finally:
        interrupt.restore()
    if checkpoints.interrupted_at is not None:
        venv.close()
        print(f"interrupted at step {model.num_timesteps:,}: saved {checkpoints.interrupted_at} (continue with --resume)",
              flush=True)
        raise KeyboardInterrupt
    save_checkpoint(model, run_dir / "final_model.zip", vec_normalize)
    venv.close()
    wall = time.perf_counter() - started
    print(f"trained {model.num_timesteps:,} steps ({model.num_timesteps - steps_before:,} in this run, {wall:.0f} s) "
          f"→ {run_dir / 'final_model.zip'}", flush=True)
    return model

"""Try every documented bad-input case (bad recordings, bad IMU files, bad options and files) and print the
Markdown table of ``docs/results/bad_input_cases.md``: the case, what was run, the exit status (or
exception/warning) and the exact message the user sees.

Each case is run in-process (the command lines through their ``main``, stderr captured) on a
tiny dataset and a 4-step model made in a temporary folder; paths are shown relative to it as
``<tmp>``. A case counts as a **clear error** when it ends as expected (exit status 2 with one
line on stderr, 1 with one ``FAILED`` line for a rejected solution, or the documented exception
or warning) and the message contains what it must name (the file, column, field or value).
For a command that succeeds, what it prints on stdout matching the case's pattern (a ``WARNING``
line, a gap note) is the message. The ``sspinn import`` cases edit copies of the first 12 s of a
real CMU OpenSense export (``../shared/data/cmu_treadmill_imu_grf``, or below
``$SSPINN_SHARED_DATA``; "not run" when absent); the signal-check cases (item 14) use that trial
imported with ``sspinn import``, saved as a recording CSV + sidecar with its IMU columns edited.

Usage::

    python scripts/bad_input_cases.py > docs/results/bad_input_cases.md   # ~30 s
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import pickle
import re
import socket
import subprocess
import sys
import tempfile
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import yaml

from sspinn.data.dataset import Dataset, Labels, Recording
from sspinn.model.conventions import GRF, SEGMENTS
from sspinn.testing import (
    OpenSenseEdit,
    axis_constant,
    edit_column,
    read_opensense_raw,
    rows_deleted,
    sensor_map_edited,
    sensor_map_with_pelvis,
    sensor_removed,
    sensor_turned,
    tiny_run,
    walking_like_3d,
    walking_recording,
    write_opensense,
    write_xsens_txt,
)
from sspinn.testing.perturbations import perturb

ROOT = Path(__file__).resolve().parents[1]

#: The real OpenSense export whose copies the ``sspinn import`` cases edit, and its sensor map.
#: ../shared/data (or $SSPINN_SHARED_DATA, as for the tests).
SHARED = Path(os.environ.get("SSPINN_SHARED_DATA") or ROOT.parent / "shared" / "data")
CMU_TRIAL = SHARED / "cmu_treadmill_imu_grf" / "Sub01" / "CSBaseline"
CMU_ACCEL = CMU_TRIAL / "OpenSim_Sub01_CSBaseline_Accel.trc.gz"
CMU_MAP = ROOT / "configs" / "sensor_maps" / "cmu_treadmill.yaml"


@dataclass
class Outcome:
    status: str  # "exit 2", "ValueError", "UserWarning", ...
    message: str


@dataclass
class Case:
    item: str
    name: str
    run: str  # what the user did
    expect_status: str
    must_name: str  # a substring the message must contain
    call: Callable[[], Outcome]


#: A progress bar's line on stderr (tqdm: "training:  50%|…"), not a message.
PROGRESS = re.compile(r"^[\w ]+:\s+\d+%\|")


def cli(main: Callable[[list[str]], int], argv: list[str], shown: str | None = None) -> Outcome:
    """Run a command line in-process: its exit status and last stderr line, or, when it succeeds
    and ``shown`` (a regular expression) is given, the stdout lines matching it (joined by " / ")."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse
            code = exc.code
    lines = [line for line in err.getvalue().splitlines() if line.strip() and not PROGRESS.match(line)]
    if code == 0 and lines and all(line.startswith("WARNING: ") for line in lines):  # warnings of a run that succeeds
        return Outcome("exit 0", " / ".join(lines))
    status = f"exit {code}" + ("" if len(lines) == 1 or (code == 0 and not lines) else f" ({len(lines)} lines)")
    printed = [line.strip() for line in out.getvalue().splitlines() if shown and re.search(shown, line)]
    return Outcome(status, " / ".join(printed) if code == 0 and printed else lines[-1] if lines else "")


def raises(fn: Callable[[], object]) -> Outcome:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            fn()
        except Exception as exc:  # noqa: BLE001 - the point is to show what comes out
            return Outcome(type(exc).__name__, str(exc))
    if caught:
        return Outcome(caught[0].category.__name__, str(caught[0].message))
    return Outcome("no error", "")


def main() -> None:
    from agents.__main__ import main as agents_main
    from envs import BatchedSagittalWalker, SagittalWalkerEnv
    from predictive import __main__ as predictive_cli
    from sspinn.cli import main as sspinn_main
    from sspinn.run_folder import RunLock

    tmp = Path(tempfile.mkdtemp(prefix="bad_input_"))
    data, cfg, run = tiny_run(tmp)
    model = run / "model.pt"
    train = ["train", "--config", str(cfg), "--data", str(data)]

    def infer_with(path: Path) -> Outcome:
        return cli(sspinn_main, ["infer", "--model", str(path), "--data", str(data), "--out", str(tmp / "o")])

    def model_file(name: str, make: Callable[[Path], object]) -> Path:
        path = tmp / "models" / name
        path.parent.mkdir(exist_ok=True)
        make(path)
        return path

    class RunsCode:
        def __reduce__(self):
            return (os.system, (f"touch {tmp / 'pwned'}",))

    # a walking-like recording to corrupt
    def recording(edit_csv: Callable[[list[str]], list[str]] | None = None, edit_meta: Callable[[dict], object] | None = None,
                  raw: Callable[[bytes], bytes] | None = None) -> Path:
        folder = tmp / f"rec{len(list(tmp.glob('rec*')))}"
        rec = walking_recording()
        csv = Recording(name=rec.name, imu=rec.imu, segments=rec.segments, height=1.75, mass=70.0).save(folder)
        if edit_csv:
            csv.write_text("\n".join(edit_csv(csv.read_text().splitlines())) + "\n")
        if edit_meta:
            meta = json.loads(csv.with_suffix(".json").read_text())
            out = edit_meta(meta)
            csv.with_suffix(".json").write_text(json.dumps(meta if out is None else out))
        if raw:
            csv.write_bytes(raw(csv.read_bytes()))
        return csv

    def column(name: str, fn: Callable[[float], float]) -> Callable[[list[str]], list[str]]:
        return lambda lines: edit_column(lines, name, fn)

    def columns(names: list[str], fn: Callable[[float], float]) -> Callable[[list[str]], list[str]]:
        def edit(lines: list[str]) -> list[str]:
            for n in names:
                lines = column(n, fn)(lines)
            return lines
        return edit

    def infer_rec(csv: Path) -> Outcome:
        return cli(sspinn_main, ["infer", "--model", str(model), "--data", str(csv), "--out", str(tmp / "o")])

    def sidecar(edit: Callable[[dict], object]) -> Path:
        return recording(edit_meta=edit)

    def nan_network(command: str, column: int = 5, value: float = float("nan")) -> Outcome:
        from sspinn.estimator.network import SSPINNposeNet

        real = SSPINNposeNet.forward

        def forward(self, x, *a, **k):
            raw, state = real(self, x, *a, **k)
            raw = raw.clone()
            raw[:, 30:, column] = value
            return raw, state

        SSPINNposeNet.forward = forward
        try:
            return cli(sspinn_main, [command, "--model", str(model), "--data", str(data), "--out", str(tmp / "o")])
        finally:
            SSPINNposeNet.forward = real

    def stale_lock() -> Outcome:
        dead = subprocess.Popen([sys.executable, "-c", "pass"])
        dead.wait()
        folder = tmp / "stale"
        folder.mkdir()
        (folder / ".lock").write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname(), "started": 0.0,
                                                  "command": "sspinn train ..."}))
        return raises(lambda: RunLock(folder).acquire().release())

    def evaluate_twice() -> Outcome:
        args = ["evaluate", "--model", str(model), "--data", str(data), "--out", str(tmp / "evaluated")]
        cli(sspinn_main, args)
        return cli(sspinn_main, args, shown="^NOTE:")

    def import_other_subject() -> Outcome:
        folder = tmp / "two_subjects"
        imu_import(extra=("--subject", "A"), out=folder)
        return imu_import(extra=("--subject", "B"), out=folder, shown="^NOTE:")

    def busy() -> Outcome:
        with RunLock(tmp / "busy"):
            return cli(sspinn_main, [*train, "--out", str(tmp / "busy")])

    def truncated_checkpoint(flag: str, extra: tuple[str, ...] = ()) -> Outcome:
        out = tmp / f"resume{flag}{len(extra)}"
        out.mkdir()
        good = (run / "checkpoint.pt").read_bytes()
        (out / "checkpoint.pt").write_bytes(good if extra else good[: len(good) // 3])
        return cli(sspinn_main, [*train, "--out", str(out), flag, *extra])

    def model_as_checkpoint() -> Outcome:
        out = tmp / "resume_model"
        out.mkdir()
        (out / "checkpoint.pt").write_bytes(model.read_bytes())
        return cli(sspinn_main, [*train, "--out", str(out), "--resume"])

    def nan_weights(path: Path) -> None:
        state = torch.load(model, weights_only=True)
        next(iter(state["model"].values())).fill_(float("nan"))
        torch.save(state, path)

    def unlabelled() -> Outcome:
        rec = Dataset.open(data).load("test")[0]
        rec.labels = None
        Dataset.write(tmp / "unlabelled", {"test": [rec]})
        return cli(sspinn_main, ["evaluate", "--model", str(model), "--data", str(tmp / "unlabelled"), "--out", str(tmp / "rep")])

    def bad_solution() -> Outcome:
        from predictive.ocp import cli as solve_cli
        from predictive.ocp.collocation import solve_predictive

        sol = solve_predictive(0.0, n_nodes=6, duration=0.4)
        sol.tau = sol.tau + 50.0
        real = solve_cli.solve_predictive
        solve_cli.solve_predictive = lambda *a, **k: sol
        try:
            return cli(predictive_cli.main, ["solve", "--speed", "0", "--nodes", "6", "--duration", "0.4", "--out", str(tmp / "s")])
        finally:
            solve_cli.solve_predictive = real

    def nan_stride() -> Outcome:
        folder = tmp / "stride"
        folder.mkdir()
        (folder / "meta.json").write_text('{"stride_duration_s": {"mean": 1.1}, "samples_per_stride": 2}')
        (folder / "signals.csv").write_text("pelvis_acc_x,pelvis_acc_y,pelvis_gyr_z\n0,9.8,nan\n0,9.8,0.1\n")
        return cli(predictive_cli.main, ["track-imu", "--data", str(folder), "--out", str(tmp / "t")])

    def env_step(action: np.ndarray) -> Callable[[], object]:
        def go() -> None:
            env = SagittalWalkerEnv()
            env.reset(seed=0)
            env.step(action)
        return go

    def after_end(truncate: bool) -> Callable[[], object]:
        def go() -> None:
            env = SagittalWalkerEnv(max_episode_steps=1)
            env.reset(seed=0)
            if not truncate:
                q, u = env.state
                q[2] = 1.2
                env.set_state(q, u)
            env.step(np.zeros(6))
            env.step(np.zeros(6))
        return go

    def batched_nan() -> None:
        env = BatchedSagittalWalker(3, device="cpu")
        env.reset(seed=0)
        a = torch.zeros(3, 6, dtype=env.dtype)
        a[1, 4] = float("nan")
        env.step(a)

    def time_at(rate: float) -> Callable[[list[str]], list[str]]:
        return lambda lines: [lines[0]] + [f"{k / rate!r}," + line.split(",", 1)[1] for k, line in enumerate(lines[1:])]

    def cell(k: int, value: str) -> Callable[[list[str]], list[str]]:
        def edit(lines: list[str]) -> list[str]:
            v = lines[6].split(",")
            v[k] = value
            return [*lines[:6], ",".join(v), *lines[7:]]
        return edit

    def placement_cm(meta: dict) -> None:
        meta["imu"]["placement"]["tibia_r"]["position_m"] = [0.0, -22.5]

    def placement_empty(meta: dict) -> None:
        meta["imu"]["placement"]["pelvis"]["position_m"] = []

    cmu = read_opensense_raw(CMU_ACCEL, end_s=12.0) if CMU_ACCEL.exists() else None
    cmu_30s = read_opensense_raw(CMU_ACCEL, end_s=32.0) if CMU_ACCEL.exists() else None

    def imu_import(edit: OpenSenseEdit | None = None, smap: dict | None = None, shown: str = "WARNING:", end_s: int = 10,
                   extra: tuple[str, ...] = (), out: Path | None = None) -> Outcome:
        """``sspinn import --end <end_s>`` of an (edited) copy of the CMU excerpt (12 s, or 32 s for
        ``end_s`` > 10) with the CMU map or ``smap``."""
        if cmu is None:
            return Outcome("not run", f"{CMU_ACCEL} absent")
        folder = tmp / f"imu{len(list(tmp.glob('imu*')))}"
        folder.mkdir()
        raw = cmu if end_s <= 10 else cmu_30s
        time, sensors = edit(*raw) if edit else raw
        accel = write_opensense(folder, "OpenSim_Sub01_CSBaseline", sensors, time=time)
        path = CMU_MAP
        if smap is not None:
            path = folder / "map.yaml"
            path.write_text(yaml.safe_dump(smap, sort_keys=False))
        return cli(sspinn_main, ["import", "--imu", str(accel), "--sensor-map", str(path), "--height", "1.81", "--mass", "66.7",
                                 "--end", str(end_s), "--out", str(out or folder / "out"), *extra], shown)

    def imu_import_news(edit: OpenSenseEdit) -> Outcome:
        """:func:`imu_import` of an edited copy, less the warnings the untouched copy prints too."""
        before, after = imu_import().message.split(" / "), imu_import(edit)
        return Outcome(after.status, " / ".join(line for line in after.message.split(" / ") if line and line not in before))

    agents = AgentRuns(tmp, agents_main)

    def generator() -> Path:
        """An untrained gait generator whose file says it was trained on 1–1.5 m/s."""
        from predictive.generator.gait_generator import GaitGeneratorNet, GeneratorConfig, save_generator

        path = tmp / "generator.pt"
        if not path.exists():
            save_generator(GaitGeneratorNet(2, 8, 1).double(), path, GeneratorConfig(speeds=(1.0, 1.5), harmonics=2, hidden=8, layers=1))
        return path

    # signal checks: edited copies of the real CMU excerpt imported to a recording CSV + sidecar
    real = real_recordings(tmp) if cmu is not None else None

    def real_infer(edit: Callable[[np.ndarray, tuple[str, ...]], np.ndarray] | None = None, meta: Callable[[dict], object] | None = None,
                   seconds: float = 20.0, name: str = "walk") -> Outcome:
        """``sspinn infer`` of the first ``seconds`` of the imported excerpt with its IMU array edited."""
        if real is None:
            return Outcome("not run", f"{CMU_ACCEL} absent")
        rec = real["whole"]
        imu = rec.imu[: int(seconds * 100)]
        imu = edit(imu, rec.segments) if edit else imu
        folder = tmp / f"real{len(list(tmp.glob('real*')))}"
        csv = Recording(name=name, imu=imu, segments=rec.segments, height=rec.height, mass=rec.mass,
                        placement=rec.placement).save(folder)
        if meta:
            sidecar_path = csv.with_suffix(".json")
            content = json.loads(sidecar_path.read_text())
            meta(content)
            sidecar_path.write_text(json.dumps(content))
        return infer_rec(csv)

    def columns_of(segment: str, channels: list[int], fn: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray, tuple[str, ...]], np.ndarray]:
        def edit(imu: np.ndarray, segments: tuple[str, ...]) -> np.ndarray:
            out = imu.copy()
            idx = list(range(len(segments))) if segment == "all" else [segments.index(segment)]
            for i in idx:
                out[:, i, channels] = fn(imu[:, i, channels])
            return out
        return edit

    def swapped(a: str, b: str) -> Callable[[np.ndarray, tuple[str, ...]], np.ndarray]:
        def edit(imu: np.ndarray, segments: tuple[str, ...]) -> np.ndarray:
            out = imu.copy()
            i, j = segments.index(a), segments.index(b)
            out[:, [i, j]] = imu[:, [j, i]]
            return out
        return edit

    def rate(factor: float) -> Callable[[np.ndarray, tuple[str, ...]], np.ndarray]:
        return lambda imu, segments: perturb(imu, segments, "rate", np.random.default_rng(0), factor=factor)[0]

    def on_table(segment: str) -> Callable[[np.ndarray, tuple[str, ...]], np.ndarray]:
        def edit(imu: np.ndarray, segments: tuple[str, ...]) -> np.ndarray:
            rng, out = np.random.default_rng(1), imu.copy()
            i = segments.index(segment)
            out[:, i] = [0.3, 9.8, 0.0] + rng.normal(0, [0.02, 0.02, 0.005], size=(len(imu), 3))
            return out
        return edit

    def labelled(edit: Callable[[Recording], Recording]) -> Outcome:
        """``Recording.load`` of the imported excerpt with GRF labels, edited."""
        if real is None:
            return Outcome("not run", f"{CMU_ACCEL} absent")
        folder = tmp / f"lab{len(list(tmp.glob('lab*')))}"
        csv = edit(real["labelled"]).save(folder)
        return raises(lambda: Recording.load(csv))

    def relabel(rec: Recording, grf: np.ndarray | None = None, mass: float | None = None) -> Recording:
        labels = Labels.from_columns({c: (grf if grf is not None else rec.labels.grf)[:, k] for k, c in enumerate(GRF)},
                                     rec.n_samples)
        return Recording(name="walk_grf", imu=rec.imu, segments=rec.segments, height=rec.height, mass=mass or rec.mass,
                         placement=rec.placement, labels=labels)

    def imu3d(name: str, fn: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]) -> OpenSenseEdit:
        return lambda time, sensors: (time, {**sensors, name: fn(*sensors[name])})

    def table3d(name: str) -> OpenSenseEdit:
        def edit(time: np.ndarray, sensors: dict) -> tuple[np.ndarray, dict]:
            rng = np.random.default_rng(2)
            acc = np.array([0.2, 9.8, 0.3]) + rng.normal(0, 0.02, (len(time), 3))
            return time, {**sensors, name: (acc, rng.normal(0, 0.005, (len(time), 3)))}
        return edit

    noise = np.random.default_rng(3)
    legs = tuple(f"{k}_{s}_imu_offset_imu" for k in ("femur", "tibia", "toes") for s in "rl")
    acc = [f"pelvis_acc_{a}" for a in "xy"]
    def model_copy() -> Path:
        folder = tmp / "export"
        folder.mkdir(exist_ok=True)
        (folder / "model.pt").write_bytes(model.read_bytes())
        (folder / "checkpoint.pt").write_bytes((run / "checkpoint.pt").read_bytes())
        return folder / "model.pt"

    def export_onto(path: Path, name: str) -> Outcome:
        before = (path.parent / name).read_bytes()
        out = cli(sspinn_main, ["export", "--model", str(path), "--out", str(path.parent / name)], shown="^NOTE:")
        assert (path.parent / name).read_bytes() == before, f"export replaced {name}"
        return out

    def linked_lock(symbolic: bool) -> Outcome:
        victim = tmp / "victim"
        victim.write_text("precious\n")
        folder = tmp / ("r" if symbolic else "h")
        folder.mkdir(exist_ok=True)
        (folder / ".lock").unlink(missing_ok=True)
        if symbolic:
            (folder / ".lock").symlink_to(victim)
        else:
            os.link(victim, folder / ".lock")
        out = cli(sspinn_main, [*train, "--out", str(folder)])
        assert victim.read_text() == "precious\n", "the lock truncated the file it points to"
        return out

    def import_twice() -> Outcome:
        imu_import(extra=("--name", "X"), out=tmp / "again")
        return imu_import(extra=("--name", "X"), out=tmp / "again", shown="^NOTE:")

    def escaping_index() -> Outcome:
        (tmp / "outside").mkdir(exist_ok=True)
        for suffix in (".csv", ".json"):
            (tmp / "outside" / f"secret{suffix}").write_text((data / f"a{suffix}").read_text())
        folder = tmp / "escaping"
        folder.mkdir(exist_ok=True)
        (folder / "dataset.json").write_text(json.dumps({"splits": {"test": ["../outside/secret"]}}))
        return cli(sspinn_main, ["infer", "--model", str(model), "--data", str(folder), "--out", str(tmp / "o_escape")])

    def fifo_data() -> Outcome:
        folder = tmp / "fifo"
        folder.mkdir(exist_ok=True)
        (folder / "fifo.csv").write_text((data / "a.csv").read_text())
        os.mkfifo(folder / "fifo.json")
        return cli(sspinn_main, ["infer", "--model", str(model), "--data", str(folder / "fifo.csv"), "--out", str(tmp / "o_fifo")])

    def big_data() -> Outcome:
        folder = tmp / "big"
        folder.mkdir(exist_ok=True)
        (folder / "big.json").write_text((data / "a.json").read_text())
        with open(folder / "big.csv", "wb") as fh:  # sparse: no disk used
            fh.truncate(2 << 30)
        return cli(sspinn_main, ["infer", "--model", str(model), "--data", str(folder / "big.csv"), "--out", str(tmp / "o_big")])

    def huge_agents() -> Outcome:
        text = yaml.safe_dump({"algo": "ppo", "total_timesteps": 1000, "hyperparameters": {"n_steps": 10**8}})
        return cli(agents_main, ["train", "--config", str(_written(tmp / "huge_agents.yaml", text)), "--out", str(tmp / "ag_huge")])

    def device_case(flag: str, value: str) -> Outcome:
        if torch.cuda.is_available() and "tpu" not in value:
            return Outcome("not run", "a CUDA GPU is visible")
        return cli(sspinn_main, [*train, "--out", str(tmp / "b"), flag, value])

    def latin1(path: Path) -> Path:
        path.write_bytes("# caf\xe9\nsensors: {}\n".encode("latin-1"))
        return path

    def xsens_rates() -> Outcome:
        folder = tmp / "xsens_rates"
        folder.mkdir(exist_ok=True)
        rng = np.random.default_rng(5)
        files = [write_xsens_txt(folder / f"{name}.txt", *walking_like_3d(n, rng, rate), rate=rate, time_format="blank")
                 for name, n, rate in (("pelvis", 600, 100.0), ("thigh", 360, 60.0))]
        smap = _written(folder / "map.yaml", "sensors:\n  pelvis: pelvis\n  thigh: femur_r\n")
        return cli(sspinn_main, ["import", "--imu", *map(str, files), "--sensor-map", str(smap), "--height", "1.8", "--mass",
                                 "70", "--out", str(folder / "out")])

    def left_leg_turned(imu: np.ndarray, segments: tuple[str, ...]) -> np.ndarray:
        out = imu.copy()
        for s in ("femur_l", "tibia_l", "foot_l"):
            out[:, segments.index(s), 0] *= -1
            out[:, segments.index(s), 2] *= -1
        return out

    def duplicate_sidecar_key() -> Outcome:
        if real is None:
            return Outcome("not run", f"{CMU_ACCEL} absent")
        rec = real["whole"]
        csv = Recording(name="walk", imu=rec.imu[:2000], segments=rec.segments, height=rec.height, mass=rec.mass,
                        placement=rec.placement).save(tmp / "duplicate_key")
        sidecar = csv.with_suffix(".json")
        sidecar.write_text(sidecar.read_text().replace("{", '{"format": "sspinn-recording", ', 1))
        return infer_rec(csv)

    def reset_then(env: SagittalWalkerEnv) -> SagittalWalkerEnv:
        env.reset(seed=0)
        return env

    def relative_config() -> Outcome:
        here = Path.cwd()
        os.chdir(tmp)
        try:
            return cli(sspinn_main, ["train", "--config", "configs/sspinn/demo.yaml", "--data", str(data), "--out", str(tmp / "b")])
        finally:
            os.chdir(here)

    cases = [
        # 1. one run per folder
        Case("1", "second training into a folder in use", "sspinn train --out <run in use>", "exit 2", "in use by PID", busy),
        Case("1", "stale lock of a dead process", "sspinn train --out <folder of a killed run>", "UserWarning", "stale lock of PID", stale_lock),
        Case("1", "training into the folder of a finished run (a new folder instead)", "sspinn train --out <finished run>", "exit 0",
             "holds a run (model.pt, checkpoint.pt); writing to", lambda: cli(sspinn_main, [*train, "--out", str(run), "--steps", "2"], shown="^NOTE:")),
        Case("1", "adapting into the folder of the model it starts from", "sspinn adapt --model run/model.pt --out run", "exit 2",
             "is the folder of the model", lambda: cli(sspinn_main, ["adapt", "--model", str(model), "--data", str(data), "--out", str(run)])),
        Case("1", "evaluating into a folder holding an evaluation (a new folder instead)", "sspinn evaluate --out <evaluated>", "exit 0",
             "holds an evaluation; writing to", lambda: evaluate_twice()),
        Case("1", "import: a recording named dataset", "sspinn import --name dataset", "exit 2", "'dataset' is not a usable recording name",
             lambda: imu_import(extra=("--name", "dataset"))),
        Case("1", "import: a recording name with a path", "sspinn import --name ../../x", "exit 2", "'../../x' is not a usable recording name",
             lambda: imu_import(extra=("--name", "../../x"))),
        Case("1", "import: another subject's recording of the same name into one folder", "sspinn import --subject B (after --subject A)",
             "exit 0", "holds a recording; writing to",
             lambda: import_other_subject()),
        # 2. model files
        Case("2", "crafted pickle that runs a shell command", "sspinn infer --model evil.pt", "exit 2", "could run code",
             lambda: infer_with(model_file("evil.pt", lambda p: torch.save({"model": RunsCode()}, p)))),
        Case("2", "random bytes", "sspinn infer --model random.pt", "exit 2", "random.pt",
             lambda: infer_with(model_file("random.pt", lambda p: p.write_bytes(np.random.default_rng(0).bytes(4096))))),
        Case("2", "empty file", "sspinn infer --model empty.pt", "exit 2", "empty.pt",
             lambda: infer_with(model_file("empty.pt", lambda p: p.write_bytes(b"")))),
        Case("2", "truncated model", "sspinn infer --model half.pt", "exit 2", "truncated",
             lambda: infer_with(model_file("half.pt", lambda p: p.write_bytes(model.read_bytes()[: model.stat().st_size // 2])))),
        Case("2", "a folder", "sspinn infer --model folder.pt", "exit 2", "is a folder",
             lambda: infer_with(model_file("folder.pt", lambda p: p.mkdir()))),
        Case("2", "torch file without the model entries", "sspinn infer --model keys.pt", "exit 2", "lacks the entries",
             lambda: infer_with(model_file("keys.pt", lambda p: torch.save({"weights": torch.zeros(3)}, p)))),
        Case("2", "torch file holding a list", "sspinn infer --model list.pt", "exit 2", "holds a list",
             lambda: infer_with(model_file("list.pt", lambda p: torch.save([1, 2, 3], p)))),
        Case("2", "newer format version", "sspinn infer --model v2.pt", "exit 2", "newer than this sspinn",
             lambda: infer_with(model_file("v2.pt", lambda p: torch.save({"format": "sspinn-model", "version": 2}, p)))),
        Case("2", "another kind of file (a gait generator)", "sspinn infer --model gen.pt", "exit 2", "gait-generator",
             lambda: infer_with(model_file("gen.pt", lambda p: torch.save({"format": "gait-generator", "version": 1}, p)))),
        Case("2", "raw pickle (not a torch zip)", "sspinn infer --model pickle.pt", "exit 2", "not a torch file",
             lambda: infer_with(model_file("pickle.pt", lambda p: p.write_bytes(pickle.dumps({"model": 1}))))),
        Case("2", "missing file", "sspinn infer --model missing.pt", "exit 2", "no such file",
             lambda: infer_with(tmp / "models" / "missing.pt")),
        Case("2/4", "NaN weights", "sspinn infer --model nan.pt", "exit 2", "non-finite",
             lambda: infer_with(model_file("nan.pt", nan_weights))),
        Case("2", "--resume on a truncated checkpoint", "sspinn train --resume", "exit 2", "checkpoint.pt: truncated",
             lambda: truncated_checkpoint("--resume")),
        Case("2", "--auto-resume on a truncated checkpoint", "sspinn train --auto-resume", "exit 2", "checkpoint.pt: truncated",
             lambda: truncated_checkpoint("--auto-resume")),
        Case("2", "--resume with another network size", "sspinn train --resume --set network.hidden=16", "exit 2",
             "does not fit this run", lambda: truncated_checkpoint("--resume", ("--set", "network.hidden=16", "--steps", "5"))),
        Case("2", "a model file given as checkpoint", "cp model.pt checkpoint.pt; sspinn train --resume", "exit 2",
             "not one of ['sspinn-checkpoint']", model_as_checkpoint),
        # 3. recordings
        Case("3", "pelvis gyroscope in deg/s (peak 35)", "sspinn infer --data walk.csv", "exit 2", "'pelvis_gyr_z'",
             lambda: infer_rec(recording(column("pelvis_gyr_z", lambda v: np.degrees(v) * 0.6)))),
        Case("3", "foot gyroscope in deg/s", "sspinn infer --data walk.csv", "exit 2", "'foot_r_gyr_z'",
             lambda: infer_rec(recording(column("foot_r_gyr_z", np.degrees)))),
        Case("3", "accelerometers in cm/s²", "sspinn infer --data walk.csv", "exit 2", "cm/s²",
             lambda: infer_rec(recording(columns(acc, lambda v: v * 100)))),
        Case("3", "accelerometers ×6 (wrong scale)", "sspinn infer --data walk.csv", "exit 2", "far above",
             lambda: infer_rec(recording(columns(acc, lambda v: v * 6)))),
        Case("3", "accelerometers in g", "sspinn infer --data walk.csv", "exit 2", "units of g",
             lambda: infer_rec(recording(columns(acc, lambda v: v / 9.81)))),
        Case("3", "accelerometer value 1e308", "sspinn infer --data walk.csv", "exit 2", "1e+308",
             lambda: infer_rec(recording(column("pelvis_acc_x", lambda v: 1e308)))),
        Case("3", "accelerometers without gravity (linear acceleration)", "sspinn infer --data walk.csv", "exit 2", "lack gravity",
             lambda: infer_rec(recording(column("pelvis_acc_y", lambda v: v - 9.81)))),
        Case("3", "all-zero gyroscope (dead sensor)", "sspinn infer --data walk.csv", "exit 2", "'tibia_l_gyr_z' is constant",
             lambda: infer_rec(recording(column("tibia_l_gyr_z", lambda v: 0.0)))),
        Case("3", "saturated gyroscope (clipped at 6 rad/s)", "sspinn infer --data walk.csv", "exit 2", "clipped at 6",
             lambda: infer_rec(recording(column("foot_r_gyr_z", lambda v: min(v, 6.0))))),
        Case("3", "IMU placement in cm", "sspinn infer --data walk.csv", "exit 2", "placement of tibia_r",
             lambda: infer_rec(sidecar(placement_cm))),
        Case("3", "last CSV line cut inside its final field", "sspinn infer --data walk.csv", "exit 2", "does not end with a newline",
             lambda: infer_rec(recording(raw=lambda b: b[:-3]))),
        Case("3", "time column at 100.9 Hz", "sspinn infer --data walk.csv", "exit 2", "drift from the 100 Hz grid",
             lambda: infer_rec(recording(time_at(100.9)))),
        Case("3", "time column at 50 Hz", "sspinn infer --data walk.csv", "exit 2", "column 'time'",
             lambda: infer_rec(recording(time_at(50.0)))),
        Case("3", "NaN in a channel", "sspinn infer --data walk.csv", "exit 2", "non-finite",
             lambda: infer_rec(recording(cell(3, "nan")))),
        Case("3", "a decimal comma (ragged row)", "sspinn infer --data walk.csv", "exit 2", "row 7 has",
             lambda: infer_rec(recording(cell(3, "12,5")))),
        Case("3", "text in a number field", "sspinn infer --data walk.csv", "exit 2", "'1.2.3' is not a number",
             lambda: infer_rec(recording(cell(3, "1.2.3")))),
        Case("3", "sidecar height_m: null", "sspinn infer --data walk.csv", "exit 2", "subject.height_m",
             lambda: infer_rec(sidecar(lambda m: m["subject"].update(height_m=None)))),
        Case("3", 'sidecar height_m: "1.75 m"', "sspinn infer --data walk.csv", "exit 2", "'1.75 m'",
             lambda: infer_rec(sidecar(lambda m: m["subject"].update(height_m="1.75 m")))),
        Case("3", "sidecar height in cm (175)", "sspinn infer --data walk.csv", "exit 2", "height 175",
             lambda: infer_rec(sidecar(lambda m: m["subject"].update(height_m=175)))),
        Case("3", "sidecar is a JSON list", "sspinn infer --data walk.csv", "exit 2", "got a list",
             lambda: infer_rec(sidecar(lambda m: [m]))),
        Case("3", "UTF-8 BOM in the CSV (accepted: not an error)", "sspinn infer --data walk.csv", "exit 0", "",
             lambda: infer_rec(recording(raw=lambda b: b"\xef\xbb\xbf" + b))),
        Case("3", "fuzz: placement position_m []", "sspinn infer --data walk.csv", "exit 2", "bad imu.placement",
             lambda: infer_rec(sidecar(placement_empty))),
        Case("3", "fuzz: sidecar segments not a list", "sspinn infer --data walk.csv", "exit 2", "imu.segments",
             lambda: infer_rec(sidecar(lambda m: m["imu"].update(segments="pelvis")))),
        Case("3", "fuzz: empty column name in the header", "sspinn infer --data walk.csv", "exit 2", "empty column name",
             lambda: infer_rec(recording(lambda lines: [lines[0] + ","] + [line + ",0" for line in lines[1:]]))),
        Case("3", "fuzz: averaged stride with a corrupt value", "python -m predictive track-imu --data stride", "exit 2", "signals.csv",
             lambda: cli(predictive_cli.main, ["track-imu", "--data", str(_corrupt_stride(tmp)), "--out", str(tmp / "t")])),
        Case("3", "--periods 0", "sspinn infer --periods 0", "exit 2", "--periods",
             lambda: cli(sspinn_main, ["infer", "--model", str(model), "--data", str(data), "--out", "o", "--periods", "0"])),
        Case("3", "--periods -3", "sspinn infer --periods -3", "exit 2", "--periods",
             lambda: cli(sspinn_main, ["infer", "--model", str(model), "--data", str(data), "--out", "o", "--periods", "-3"])),
        # 4. outputs
        Case("4", "network producing NaN: infer", "sspinn infer (NaN network)", "exit 2", "not finite from sample 30",
             lambda: nan_network("infer")),
        Case("4", "network producing NaN: evaluate", "sspinn evaluate (NaN network)", "exit 2", "not finite from sample 30",
             lambda: nan_network("evaluate")),
        Case("4", "network producing an impossible joint angle: infer", "sspinn infer (patched network)", "exit 2",
             "no human movement reaches", lambda: nan_network("infer", 5, 50.0)),
        Case("4", "network producing an impossible pelvis speed: evaluate", "sspinn evaluate (patched network)", "exit 2",
             "forward pelvis speed", lambda: nan_network("evaluate", 8, 500.0)),
        Case("4", "evaluate without labels (no folder left)", "sspinn evaluate --data unlabelled", "exit 2", "no labels", unlabelled),
        Case("4", "evaluate --skip beyond the recording", "sspinn evaluate --skip 500", "exit 2", "--skip 500",
             lambda: cli(sspinn_main, ["evaluate", "--model", str(model), "--data", str(data), "--out", str(tmp / "r"), "--skip", "500"])),
        # 5. predictive
        *[Case("5", f"solve {' '.join(a)}", f"python -m predictive solve {' '.join(a)}", "exit 2", m,
               lambda a=a: cli(predictive_cli.main, ["solve", *a, "--out", str(tmp / "x")]))
          for a, m in ((("--speed", "50"), "--speed 50"), (("--speed", "-1"), "--speed -1"), (("--speed", "nan"), "--speed nan"),
                       (("--speed", "1.3", "--height", "175"), "height 175"), (("--speed", "1.3", "--mass", "0"), "mass 0"),
                       (("--speed", "1.3", "--nodes", "2"), "--nodes: 2 is outside 4–1000"),
                       (("--speed", "1.3", "--nodes", "1000000"), "--nodes: 1000000 is outside 4–1000"),
                       (("--speed", "1.3", "--rate-hz", "1e6"), "--rate-hz: 1e6 is outside 1–1000 Hz"),
                       (("--speed", "1.3", "--guess", "missing.npz"), "missing.npz"))],
        Case("5", "solution violating the dynamics (residual at its nodes)", "python -m predictive solve (bad solution)", "exit 1",
             "Kane residual at its own nodes", bad_solution),
        Case("5", "track-imu on a missing folder", "python -m predictive track-imu --data nowhere", "exit 2", "nowhere",
             lambda: cli(predictive_cli.main, ["track-imu", "--data", str(tmp / "nowhere"), "--out", str(tmp / "t")])),
        Case("5", "track-imu with NaN in the data", "python -m predictive track-imu --data stride", "exit 2", "pelvis_gyr_z", nan_stride),
        # 6. environment
        Case("6", "NaN action", "env.step([0, 0, nan, 0, 0, 0])", "ValueError", "nan", lambda: raises(env_step(np.array([0, 0, np.nan, 0, 0, 0])))),
        Case("6", "inf action", "env.step([inf, ...])", "ValueError", "inf", lambda: raises(env_step(np.array([np.inf, 0, 0, 0, 0, 0])))),
        Case("6", "NaN action, batched env", "BatchedSagittalWalker.step(actions with NaN in row 1)", "ValueError", "[1]", lambda: raises(batched_nan)),
        Case("6", "step after terminated", "env.step() after terminated", "UserWarning", "call reset()", lambda: raises(after_end(False))),
        Case("6", "step after truncated", "env.step() after truncated", "UserWarning", "call reset()", lambda: raises(after_end(True))),
        # 7. options
        *[Case("7", f"--set {s}", f"sspinn train --set {s}", "exit 2", m, lambda s=s: cli(sspinn_main, [*train, "--out", str(tmp / "r"), "--set", s]))
          for s, m in (("window=abc", "window"), ("lr=nan", "lr"), ("lr=fast", "lr"), ("lr=-1", "lr"), ("network.hidden=big", "network.hidden"))],
        Case("2", "agents: crafted SB3 checkpoint with a pickled payload", "python -m agents evaluate --checkpoint evil.zip",
             "exit 2", "refusing", lambda: crafted_agent(tmp, RunsCode(), agents_main)),
        Case("2", "agents: crafted VecNormalize statistics", "load_agent(...) reading evil_vecnormalize.pkl", "UnsafeCheckpointError",
             "refusing to load posix.system", lambda: raises(lambda: _load_statistics(tmp, RunsCode()))),
        Case("all", "agents: missing config", "python -m agents train --config missing.yaml", "exit 2", "missing.yaml",
             lambda: cli(agents_main, ["train", "--config", str(tmp / "missing.yaml"), "--out", str(tmp / "ag")])),
        *[Case("7", f"agents: a config that {what}", f"python -m agents train --config {name}.yaml ({'; '.join(text.split(chr(10))[:-1])})", "exit 2", m,
               lambda name=name, text=text: cli(agents_main, ["train", "--config", str(_written(tmp / f"{name}.yaml", text)),
                                                              "--out", str(tmp / "ag")]))
          for what, name, text, m in (("extends itself", "loop", "extends: loop.yaml\nalgo: ppo\n", "closes a loop"),
                                      ("extends a missing file", "orphan", "extends: gone.yaml\nalgo: ppo\n",
                                       "orphan.yaml: extends:"))],
        Case("2", "agents: --resume with crafted VecNormalize statistics", "python -m agents train --resume "
             "(checkpoints/model_vecnormalize_64_steps.pkl crafted)", "exit 2", "refusing to load posix.system",
             lambda: agents.resume("ppo", lambda run: (run / "checkpoints" / "model_vecnormalize_64_steps.pkl").write_bytes(
                 pickle.dumps(RunsCode())))),
        Case("2", "agents: --resume with a pickled payload as `observation_space` in the .zip (rebuilt from the config: "
             "loads safely, the payload never read)", "python -m agents train --resume (model_64_steps.zip crafted)", "exit 0",
             "resuming from", lambda: agents.resume("ppo", lambda run: agents.rewrite_data(
                 run / "checkpoints" / "model_64_steps.zip", "observation_space", RunsCode()))),
        Case("2", "agents: --resume with a pickled payload in the .zip's torch weights", "python -m agents train --resume "
             "(policy.pth crafted)", "exit 2", "holds data other than network weights",
             lambda: agents.resume("ppo", lambda run: agents.crafted_weights(run / "checkpoints" / "model_64_steps.zip", RunsCode()))),
        Case("2", "agents: --resume with a crafted replay buffer (TD3)", "python -m agents train --resume "
             "(checkpoints/model_replay_buffer_32_steps.pkl crafted)", "exit 2", "not an SB3 replay buffer (refusing to load posix.system)",
             lambda: agents.resume("td3", lambda run: (run / "checkpoints" / "model_replay_buffer_32_steps.pkl").write_bytes(
                 pickle.dumps(RunsCode())))),
        *[Case("7", f"agents: {' '.join(a)}", f"python -m agents {' '.join(a)}", "exit 2", m,
               lambda a=a: cli(agents_main, [*a, "--out", str(tmp / "ag_out")]))
          for a, m in ((("evaluate", "--checkpoint", "m.zip", "--fps", "1000"), "--fps: 1000 is outside 1–100"),
                       (("evaluate", "--checkpoint", "m.zip", "--max-steps", "1000000000"), "--max-steps: 1000000000 is outside 1–60000"),
                       (("evaluate", "--checkpoint", "m.zip", "--episodes", "0"), "--episodes: 0 is outside 1–1000"),
                       (("train", "--config", "c.yaml", "--total-timesteps", "1000000000000"), "--total-timesteps: must be an integer > 0 and <= 1e+11"))],
        # predictive options, the gait generator's training range, outputs
        *[Case("7", f"{a[0]} {' '.join(a[1:])}", f"python -m predictive {' '.join(a)}", "exit 2", m,
               lambda a=a: cli(predictive_cli.main, [*a, "--out", str(tmp / "p_out")]))
          for a, m in ((("generate", "--model", "g.pt", "--speed", "1.3", "--refine", "100000000"), "--refine: 100000000 is outside 0–5000"),
                       (("generate", "--model", "g.pt", "--speed", "1.3", "--refine", "-5"), "--refine: -5 is outside 0–5000"),
                       (("synth", "--workers", "0"), "--workers: 0 is outside 1–256"),
                       (("compare", "--seeds", "-5"), "--seeds: -5 is outside 1–1000"))],
        Case("5", "generate outside the generator's training range (trained on 1–1.5 m/s)", "python -m predictive generate --speed 3",
             "exit 2", "speed 3 m/s is outside its training range 1–1.5 m/s",
             lambda: cli(predictive_cli.main, ["generate", "--model", str(generator()), "--speed", "3", "--out", str(tmp / "gen")])),
        Case("5", "generate outside the training range with --force", "python -m predictive generate --speed 2.5 --force", "exit 0",
             "WARNING: speed 2.5 m/s is outside its training range",
             lambda: cli(predictive_cli.main, ["generate", "--model", str(generator()), "--speed", "2.5", "--force",
                                               "--out", str(tmp / "gen")])),
        Case("4", "a NaN in a generated gait's summary", "python -m predictive generate (summary with NaN)", "exit 2",
             "refusing to write non-finite nan at stride_length_m", lambda: nan_summary(generator(), tmp, predictive_cli.main)),
        Case("4", "--out below a file", "python -m predictive generate --out notes.txt/walk", "exit 2",
             "this is a file where a folder is expected", lambda: below_a_file(generator(), tmp, predictive_cli.main)),
        Case("4", "disk full while writing (file-size limit 4 kB)", "python -m predictive generate (RLIMIT_FSIZE 4096)", "exit 2",
             "walk.npz: File too large", lambda: disk_full(generator(), tmp)),
        # signal checks on the CSV path (sspinn infer of a recording CSV + sidecar: 20 s of imported real walking)
        Case("14", "real walking, untouched (no finding)", "sspinn infer --data walk.csv", "exit 0", "", lambda: real_infer()),
        Case("14", "all accelerometers negated", "sspinn infer --data walk.csv (acc × −1)", "exit 2",
             "the accelerometers are negated", lambda: real_infer(columns_of("all", [0, 1], np.negative))),
        Case("14", "acc_x/acc_y swapped on one sensor", "sspinn infer --data walk.csv (tibia_r acc_x ↔ acc_y)", "exit 0",
             "sensor tibia_r: the mean specific force (gravity) points +96°", lambda: real_infer(
                 columns_of("tibia_r", [0, 1], lambda a: a[:, ::-1]))),
        Case("14", "all gyroscopes negated", "sspinn infer --data walk.csv (gyr_z × −1)", "exit 0",
             "the gyroscopes look negated", lambda: real_infer(columns_of("all", [2], np.negative))),
        Case("14", "one shank's gyroscope negated", "sspinn infer --data walk.csv (tibia_l gyr_z × −1)", "exit 0",
             "left-leg sensors do not move like one leg", lambda: real_infer(columns_of("tibia_l", [2], np.negative))),
        Case("14", "left/right thigh columns swapped", "sspinn infer --data walk.csv (femur_r ↔ femur_l)", "exit 0",
             "femur_r leads tibia_r", lambda: real_infer(swapped("femur_r", "femur_l"))),
        Case("14", "thigh/shank columns swapped (right leg)", "sspinn infer --data walk.csv (femur_r ↔ tibia_r)", "exit 0",
             "right-leg sensors do not move like one leg", lambda: real_infer(swapped("femur_r", "tibia_r"))),
        Case("14", "60 Hz data stamped as 100 Hz (× 1.67: running's cadence; judged by the joint constraints)",
             "sspinn infer --data walk.csv (60 Hz rows)", "exit 0", "sample rate is likely wrong", lambda: real_infer(rate(100 / 60))),
        Case("14", "10 Hz data stamped as 100 Hz", "sspinn infer --data walk.csv (10 Hz rows, 59 s of walking)", "exit 0",
             "steps/s, outside 0.5–3.5 steps/s", lambda: real_infer(rate(10.0), seconds=59.0)),
        Case("14", "1 kHz data stamped as 100 Hz", "sspinn infer --data walk.csv (1 kHz rows)", "exit 0",
             "the sample rate is likely wrong (recorded at", lambda: real_infer(rate(0.1), seconds=10.0)),
        Case("14", "dead but noisy gyroscope", "sspinn infer --data walk.csv (foot_r gyr_z white noise, σ 0.3 rad/s)", "exit 0",
             "sensor foot_r: gyr_z does not move with", lambda: real_infer(columns_of(
                 "foot_r", [2], lambda g: noise.normal(0, 0.3, g.shape)))),
        Case("14", "a foot sensor lying on a table", "sspinn infer --data walk.csv (foot_l still)", "exit 0",
             "sensor foot_l is not on a moving body", lambda: real_infer(on_table("foot_l"))),
        Case("14", "sidecar placement angle in degrees", "sspinn infer --data walk.csv (imu.placement.femur_r.angle_rad: 90)",
             "exit 2", "imu.placement.femur_r.angle_rad 90: beyond ±π rad — in degrees?", lambda: real_infer(
                 meta=lambda m: m["imu"]["placement"]["femur_r"].update(angle_rad=90))),
        # signal checks of GRF labels (a labelled recording read for sspinn evaluate)
        Case("14", "GRF labels' sides swapped", "Recording.load(walk_grf.csv) (grf_*_r ↔ grf_*_l)", "SignalWarning",
             "the GRF labels' sides look swapped", lambda: labelled(lambda r: relabel(r, r.labels.grf[:, [2, 3, 0, 1]]))),
        Case("14", "GRF labels for another body mass", "Recording.load(walk_grf.csv) (mass 90 kg, labels of 66.7 kg)",
             "SignalWarning", "0.739 × the body weight (883 N for 90 kg)", lambda: labelled(lambda r: relabel(r, mass=90.0))),
        Case("14", "GRF labels at another time base", "Recording.load(walk_grf.csv) (labels 2× slower)", "SignalWarning",
             "the labels' time base or rate differs", lambda: labelled(lambda r: relabel(
                 r, np.repeat(r.labels.grf, 2, axis=0)[: r.n_samples]))),
        # signal checks on sspinn import
        Case("14", "import: one gyroscope negated (the calibration keeps gyr_z right but mirrors acc_x)",
             "sspinn import --imu <copy, tibia_r gyro × −1>", "exit 0", "sensor tibia_r",
             lambda: imu_import(imu3d("tibia_r_imu_offset_imu", lambda a, g: (a, -g)))),
        Case("14", "import: one gyroscope × 0.5",
             "sspinn import --imu <copy, femur_l gyro × 0.5>", "exit 0", "sensor femur_l",
             lambda: imu_import(imu3d("femur_l_imu_offset_imu", lambda a, g: (a, 0.5 * g)))),
        Case("14", "import: dead but noisy gyroscope", "sspinn import --imu <copy, toes_r gyro white noise>", "exit 0",
             "sensor foot_r: gyr_z does not move with", lambda: imu_import(imu3d(
                 "toes_r_imu_offset_imu", lambda a, g: (a, noise.normal(0, 0.3, g.shape))))),
        Case("14", "import: acc Y/Z swapped on one sensor (calibrated to a mirrored acc_x)",
             "sspinn import --imu <copy, femur_r acc Y ↔ Z>", "exit 0", "sensor femur_r",
             lambda: imu_import(imu3d("femur_r_imu_offset_imu", lambda a, g: (a[:, [0, 2, 1]], g)))),
        Case("14", "import: a shank sensor on a table", "sspinn import --imu <copy, tibia_l still>", "exit 0",
             "sensor tibia_l is not on a moving body", lambda: imu_import(table3d("tibia_l_imu_offset_imu"))),
        Case("14", "import: the torso sensor mapped as the pelvis (the pelvis sensor ignored)",
             "sspinn import --sensor-map <torso as pelvis> --end 30", "exit 0", "ignored sensor 'pelvis_imu_offset_imu' fits the hip joints better",
             lambda: imu_import(smap=sensor_map_with_pelvis(CMU_MAP, "torso_imu_offset_imu"), end_s=30)),
        # bad IMU files (sspinn import of edited copies of a real CMU OpenSense export)
        Case("13a", "thighs' sensors swapped between the sides in the map", "sspinn import --sensor-map thighs_swapped.yaml",
             "exit 0", "'femur_l_imu_offset_imu' (femur_r) leads 'tibia_r_imu_offset_imu' (tibia_r)",
             lambda: imu_import(smap=sensor_map_edited(CMU_MAP, legs[:2]))),
        Case("13a", "all leg sensors swapped between the sides in the map", "sspinn import --sensor-map sides_swapped.yaml",
             "exit 0", "right and left look swapped", lambda: imu_import(smap=sensor_map_edited(CMU_MAP, legs))),
        Case("13a", "a sensor mapped to a segment that does not exist", "sspinn import --sensor-map upperleg.yaml", "exit 2",
             "sensor 'femur_r_imu_offset_imu': unknown segment 'upperleg_r'",
             lambda: imu_import(smap=sensor_map_edited(CMU_MAP, femur_r_imu_offset_imu="upperleg_r"))),
        Case("13a", "the map of another export (other sensor names)", "sspinn import --sensor-map other.yaml", "exit 2",
             "sensor 'pelvis_imu' (mapped to pelvis) is not in", lambda: imu_import(smap={"sensors": {f"{s}_imu": s for s in SEGMENTS}})),
        Case("13b", "a sensor's columns removed from the .trc files", "sspinn import --imu <copy without tibia_l>", "exit 2",
             "sensor 'tibia_l_imu_offset_imu' (mapped to tibia_l) is not in", lambda: imu_import(sensor_removed("tibia_l_imu_offset_imu"))),
        Case("13c", "3 rows (0.03 s) deleted: a short gap (interpolated)", "sspinn import --imu <copy with a gap>", "exit 0",
             "sensor 'pelvis_imu_offset_imu': 3 sample(s) missing after t = 4.990 s",
             lambda: imu_import(rows_deleted(5.0, 0.03), shown=r"gap\(s\) interpolated|WARNING:")),
        Case("13c", "20 rows (0.2 s) deleted: a long gap", "sspinn import --imu <copy with a gap>", "exit 2",
             "sensor 'pelvis_imu_offset_imu': 20 sample(s) missing after t = 4.990 s", lambda: imu_import(rows_deleted(5.0, 0.2))),
        Case("13d", "shank sensor upside down (turned 180° about its medio-lateral axis), no hint", "sspinn import --imu <copy>",
             "exit 0", "sensor 'tibia_l_imu_offset_imu' (tibia_l): appears mounted upside down",
             lambda: imu_import(sensor_turned("tibia_l_imu_offset_imu", 2))),
        Case("13d", "shank sensor turned 180° about its long axis (same signals: nothing reported beyond the untouched "
             "file's own warning)", "sspinn import --imu <copy>", "exit 0", "",
             lambda: imu_import_news(sensor_turned("tibia_l_imu_offset_imu", 0))),
        Case("13e", "an accelerometer axis all zeros", "sspinn import --imu <copy>", "exit 2",
             "sensor 'tibia_l_imu_offset_imu': acc axis Y is constant", lambda: imu_import(axis_constant("tibia_l_imu_offset_imu", 0, 1))),
        Case("13e", "a gyroscope axis all zeros", "sspinn import --imu <copy>", "exit 2",
             "sensor 'femur_r_imu_offset_imu': gyr axis Z is constant", lambda: imu_import(axis_constant("femur_r_imu_offset_imu", 1, 2))),
        # nothing lost: no file replaced without --overwrite, locks never follow links
        Case("15", "export onto the model file it reads", "sspinn export --model model.pt --out model.pt", "exit 2",
             "is the model file the program is exported from", lambda: export_onto(model_copy(), "model.pt")),
        Case("15", "export onto an existing file (the run's checkpoint)", "sspinn export --out checkpoint.pt", "exit 0",
             "is an existing file; writing to", lambda: export_onto(model_copy(), "checkpoint.pt")),
        Case("15", "calibrate-quality --out onto the model file, with --overwrite", "sspinn calibrate-quality --out model.pt "
             "--overwrite", "exit 2", "is the model file being calibrated", lambda: cli(sspinn_main, [
                 "calibrate-quality", "--model", str(model_copy()), "--data", str(data), "--out", str(model_copy()),
                 "--overwrite"])),
        Case("15", "a .lock that is a symbolic link to another file", "sspinn train --out r (r/.lock → victim)", "exit 2",
             "r/.lock: is a symbolic link (to", lambda: linked_lock(symbolic=True)),
        Case("15", "a .lock that is a hard link to another file", "sspinn train --out h (h/.lock = victim)", "exit 2",
             "h/.lock: a hard link to another file; it is left untouched", lambda: linked_lock(symbolic=False)),
        Case("15", "import: a name that is another recording's calibration report", "sspinn import --name X_calibration",
             "exit 2", "'X_calibration' is not a usable recording name", lambda: imu_import(extra=("--name", "X_calibration"))),
        Case("15", "import: the same name again (same subject)", "sspinn import --name X (twice)", "exit 0",
             "again/X holds a recording; writing to", lambda: import_twice()),
        Case("15", "import: into a synthetic dataset holding a recording of that name", "sspinn import --out <tiny data> --name a",
             "exit 0", "data/a holds a recording; writing to", lambda: imu_import(
                 extra=("--name", "a"), out=data, shown="^NOTE:")),
        Case("15", "import: an empty name", "sspinn import --name ''", "exit 2", "'' is not a usable recording name",
             lambda: imu_import(extra=("--name", ""))),
        Case("15", "import: a hidden name", "sspinn import --name .hidden", "exit 2", "'.hidden' is not a usable recording name",
             lambda: imu_import(extra=("--name", ".hidden"))),
        Case("15", "import: a name with a newline", "sspinn import --name 'a\\nb'", "exit 2", "is not a usable recording name",
             lambda: imu_import(extra=("--name", "a\nb"))),
        Case("15", "dataset.json listing a path outside the folder", "sspinn infer --data <dataset.json: ../outside/secret>",
             "exit 2", "'../outside/secret' is not a usable recording name", lambda: escaping_index()),
        # hard upper bounds: refused before anything is allocated or read
        Case("16", "training steps beyond any run", "sspinn train --steps 1000000000000000", "exit 2",
             "argument --steps: must be an integer <= 1e+08", lambda: cli(sspinn_main, [*train, "--out", str(tmp / "b"),
                                                                                      "--steps", "1" + "0" * 15])),
        Case("16", "training steps beyond any run, as a setting", "sspinn train --set steps=1000000000000000", "exit 2",
             "option steps must be an integer <= 1e+08", lambda: cli(sspinn_main, [*train, "--out", str(tmp / "b"),
                                                                                 "--set", "steps=" + "1" + "0" * 15])),
        Case("16", "a batch no memory holds", "sspinn train --set batch_size=1000000000", "exit 2",
             "option batch_size must be an integer <= 1e+06", lambda: cli(sspinn_main, [*train, "--out", str(tmp / "b"),
                                                                                      "--set", "batch_size=1000000000"])),
        Case("16", "a batch beyond this machine's memory", "sspinn train --set batch_size=100000 --set window=1000", "exit 2",
             "(samples per training step) needs about", lambda: cli(sspinn_main, [*train, "--out", str(tmp / "b"), "--set",
                                                                               "batch_size=100000", "--set", "window=1000"])),
        Case("16", "a FIFO as --data", "sspinn infer --data fifo.csv", "exit 2", "fifo.json: is a FIFO (named pipe)",
             lambda: fifo_data()),
        Case("16", "a 2 GB (sparse) recording", "sspinn infer --data big.csv", "exit 2", "big.csv: 2048 MiB, more than the 1024 MiB",
             lambda: big_data()),
        Case("16", "a .trc whose time column is in ms", "sspinn import --imu <copy, time × 1000>", "exit 2",
             "(the time column in ms?)", lambda: imu_import(lambda time, sensors: (time * 1000, sensors))),
        Case("16", "an agents config whose rollout buffer no memory holds", "python -m agents train (n_steps 10⁸)", "exit 2",
             "hyperparameters.n_steps 100000000 × env.n_envs", lambda: huge_agents()),
        # one-line errors for a user's mistake
        Case("17", "device cuda on a torch without CUDA", "sspinn train --set device=cuda", "exit 2",
             "--set 'device=cuda': 'cuda'", lambda: device_case("--set", "device=cuda")),
        Case("17", "device cuda:7", "sspinn train --device cuda:7", "exit 2", "--device 'cuda:7'",
             lambda: device_case("--device", "cuda:7")),
        Case("17", "device tpu", "sspinn train --set device=tpu", "exit 2", "'tpu' is not a device sspinn trains on",
             lambda: device_case("--set", "device=tpu")),
        Case("17", "a training config that is not UTF-8", "sspinn train --config latin1.yaml", "exit 2",
             "latin1.yaml: not UTF-8 text", lambda: cli(sspinn_main, ["train", "--config", str(latin1(tmp / "latin1.yaml")), "--data",
                                                                   str(data), "--out", str(tmp / "b")])),
        Case("17", "a sensor map that is not UTF-8", "sspinn import --sensor-map latin1_map.yaml", "exit 2",
             "latin1_map.yaml: not UTF-8 text", lambda: imu_import(extra=("--sensor-map", str(latin1(tmp / "latin1_map.yaml"))))),
        Case("17", "YAML nested 5000 deep", "sspinn train --config deep.yaml", "exit 2", "deep.yaml: lists or mappings nested",
             lambda: cli(sspinn_main, ["train", "--config", str(_written(tmp / "deep.yaml", "a: " + "[" * 5000 + "]" * 5000 + "\n")),
                                       "--data", str(data), "--out", str(tmp / "b")])),
        Case("17", "adapt with a learning rate of 10⁹", "sspinn adapt --lr 1e9", "exit 2", "argument --lr: must be a number > 0 and <= 1",
             lambda: cli(sspinn_main, ["adapt", "--model", str(model), "--data", str(data), "--out", str(tmp / "b"), "--lr", "1e9"])),
        Case("17", "/dev/zero as the sensor map", "sspinn import --sensor-map /dev/zero", "exit 2",
             "/dev/zero: is a character device", lambda: imu_import(extra=("--sensor-map", "/dev/zero"))),
        Case("17", "Xsens files at different rates (60 and 100 Hz)", "sspinn import --imu a.txt b.txt", "exit 2",
             "the Xsens files' headers give different update rates", lambda: xsens_rates()),
        Case("17", "env.reset with options that are no mapping", "SagittalWalkerEnv().reset(options=[1, 2])", "TypeError",
             "must be a dict of reset options", lambda: raises(lambda: SagittalWalkerEnv().reset(options=[1, 2]))),
        # silent wrong results: now caught with their own cause (rates: docs/bad_input.md)
        Case("18", "left-leg sensors turned 180° about their long axis", "sspinn infer --data walk.csv (acc_x, gyr_z × −1 on the "
             "left leg)", "exit 0", "the right and left legs swing in phase", lambda: real_infer(left_leg_turned)),
        Case("18", "all accelerometers × 1.5", "sspinn infer --data walk.csv (acc × 1.5)", "exit 0",
             "the accelerometer looks scaled by 1.5", lambda: real_infer(columns_of("all", [0, 1], lambda a: 1.5 * a))),
        Case("18", "a gyroscope bias of 0.5 rad/s on every sensor", "sspinn infer --data walk.csv (gyr_z + 0.5)", "exit 0",
             "every gyroscope looks biased", lambda: real_infer(columns_of("all", [2], lambda g: g + 0.5))),
        Case("18", "a speed label 10× the walk's (7.69 for 0.77 m/s)", "sspinn import --speed 7.69 --end 30", "exit 0",
             "the speed label looks wrong", lambda: imu_import(extra=("--speed", "7.69"), end_s=30)),
        Case("18", "a negative loss weight", "sspinn train --set weights.kane=-1", "exit 2", "option weights.kane must be a number >= 0",
             lambda: cli(sspinn_main, [*train, "--out", str(tmp / "b"), "--set", "weights.kane=-1"])),
        Case("18", "a duplicate key in the sidecar JSON", "sspinn infer --data walk.csv (two 'format' keys)", "exit 2",
             "walk.json: not valid JSON (duplicate key 'format')", lambda: duplicate_sidecar_key()),
        # minor
        Case("19", "extends: a folder", "sspinn train --config ext.yaml (extends: /etc)", "exit 2", "/etc: is a folder",
             lambda: cli(sspinn_main, ["train", "--config", str(_written(tmp / "ext.yaml", "extends: /etc\n")), "--data", str(data),
                                       "--out", str(tmp / "b")])),
        Case("19", "--config /dev/zero", "sspinn train --config /dev/zero", "exit 2", "/dev/zero: is a character device",
             lambda: cli(sspinn_main, ["train", "--config", "/dev/zero", "--data", str(data), "--out", str(tmp / "b")])),
        Case("19", "a duplicate key in a YAML config", "sspinn train --config dup.yaml", "exit 2", "duplicate key 'steps'",
             lambda: cli(sspinn_main, ["train", "--config", str(_written(tmp / "dup.yaml", "train:\n  steps: 5\n  steps: 6\n")),
                                       "--data", str(data), "--out", str(tmp / "b")])),
        Case("19", "an empty synth configuration", "python -m predictive synth --config empty.yaml", "exit 2",
             "empty.yaml: the configuration file is empty", lambda: cli(predictive_cli.main, [
                 "synth", "--config", str(_written(tmp / "empty.yaml", "")), "--out", str(tmp / "synth_empty")])),
        Case("19", "--imu-rate with an OpenSense export", "sspinn import --imu-rate 60", "exit 2",
             "applies to Xsens files only", lambda: imu_import(extra=("--imu-rate", "60"))),
        Case("19", "a complex-valued action", "SagittalWalkerEnv().step([1j] * 6)", "ValueError", "action must be real",
             lambda: raises(lambda: reset_then(SagittalWalkerEnv()).step(np.zeros(6) + 1j))),
        Case("19", "a relative --config missing in the working folder", "sspinn train --config configs/sspinn/demo.yaml (elsewhere)",
             "exit 2", "configs/sspinn/demo.yaml: no such configuration file", lambda: relative_config()),
    ]

    rows, clear = [], 0
    for k, case in enumerate(cases, 1):
        out = case.call()
        ok = out.status == case.expect_status and (case.must_name in out.message if case.must_name else not out.message)
        clear += ok
        message = re.sub(r"\x1b\[[0-9;]*m", "", out.message).replace(str(tmp), "<tmp>").replace(f"{ROOT}/", "").replace("|", "\\|")
        rows.append(f"| {k} | {case.item} | {case.name} | `{case.run}` | {out.status} | {message or '–'} | {'yes' if ok else '**no**'} |")
    assert not (tmp / "pwned").exists(), "the crafted model file ran code"
    print("| # | item | case | what was run | result | what the user sees | clear |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(f"\n**{clear} of {len(cases)} cases → a clear error (or the documented correct behaviour).**")


def real_recordings(tmp: Path) -> dict[str, Recording]:
    """The whole CMU trial imported without GRF (``whole``) and its first 20 s with GRF labels
    (``labelled``), no figures."""
    from sspinn.imu import pipeline

    real = pipeline.plot_calibration
    pipeline.plot_calibration = lambda path, *a, **k: Path(path)
    try:
        with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            whole = pipeline.import_imu([CMU_ACCEL], CMU_MAP, 1.81, 66.7, tmp / "cmu_whole").recording
            labelled = pipeline.import_imu([CMU_ACCEL], CMU_MAP, 1.81, 66.7, tmp / "cmu_grf", end_s=20.0,
                                           grf=CMU_TRIAL / "OpenSim_Sub01_CSBaseline_GRF.mot.gz").recording
    finally:
        pipeline.plot_calibration = real
    return {"whole": whole, "labelled": labelled}


def crafted_agent(tmp: Path, payload: object, agents_main: Callable[[list[str]], int]) -> Outcome:
    import base64
    import zipfile

    from agents.config import save_config
    from tests.test_agents import tiny

    folder = tmp / "agent"
    folder.mkdir(exist_ok=True)
    save_config(tiny(), folder / "config.yaml")
    evil = base64.b64encode(pickle.dumps(payload)).decode()
    with zipfile.ZipFile(folder / "evil.zip", "w") as archive:
        archive.writestr("data", json.dumps({"policy_class": {":serialized:": evil}, "payload": {":serialized:": evil}}))
    return cli(agents_main, ["evaluate", "--checkpoint", str(folder / "evil.zip"), "--out", str(tmp / "ev")])


class AgentRuns:
    """Tiny finished agent runs (64 PPO steps; 32 TD3 steps with their replay buffer), copied and
    edited for each ``--resume`` case."""

    def __init__(self, tmp: Path, agents_main: Callable[[list[str]], int]) -> None:
        self.tmp, self.main, self.runs = tmp, agents_main, {}

    def run(self, algo: str) -> Path:
        if algo not in self.runs:
            from agents.config import config_from_dict
            from agents.train import train

            data = {"algo": algo, "seed": 3, "total_timesteps": 64 if algo == "ppo" else 32,
                    "env": {"n_envs": 1, "kwargs": {"target_speed": 1.3, "max_episode_steps": 30}},
                    "policy": {"net_arch": [8]},
                    "hyperparameters": {"n_steps": 64, "batch_size": 32, "n_epochs": 1} if algo == "ppo" else
                    {"learning_starts": 16, "batch_size": 8, "buffer_size": 200},
                    "logging": {"checkpoint_freq": 64 if algo == "ppo" else 32, "eval_freq": 0, "tensorboard": False,
                                "keep_replay_buffer": algo != "ppo"}}
            folder = self.tmp / f"agent_{algo}"
            with contextlib.redirect_stdout(io.StringIO()):
                train(config_from_dict(data), folder)
            self.runs[algo] = folder
        return self.runs[algo]

    def resume(self, algo: str, edit: Callable[[Path], object]) -> Outcome:
        import shutil

        run = Path(shutil.copytree(self.run(algo), self.tmp / f"resume_{algo}_{len(list(self.tmp.glob('resume_*')))}"))
        edit(run)
        steps = 128 if algo == "ppo" else 48
        return cli(self.main, ["train", "--config", str(run / "config.yaml"), "--out", str(run), "--resume",
                               "--total-timesteps", str(steps)], shown="resuming from")

    @staticmethod
    def rewrite_data(zip_path: Path, key: str, payload: object) -> None:
        import base64
        import zipfile

        with zipfile.ZipFile(zip_path) as archive:
            entries = {name: archive.read(name) for name in archive.namelist()}
        data = json.loads(entries["data"])
        data[key] = {":type:": "<class 'object'>", ":serialized:": base64.b64encode(pickle.dumps(payload)).decode()}
        entries["data"] = json.dumps(data).encode()
        with zipfile.ZipFile(zip_path, "w") as archive:
            for name, content in entries.items():
                archive.writestr(name, content)

    @staticmethod
    def crafted_weights(zip_path: Path, payload: object) -> None:
        import zipfile

        with zipfile.ZipFile(zip_path) as archive:
            entries = {name: archive.read(name) for name in archive.namelist()}
        buffer = io.BytesIO()
        torch.save({"payload": payload}, buffer)
        entries["policy.pth"] = buffer.getvalue()
        with zipfile.ZipFile(zip_path, "w") as archive:
            for name, content in entries.items():
                archive.writestr(name, content)


def nan_summary(model: Path, tmp: Path, main: Callable[[list[str]], int]) -> Outcome:
    from predictive.ocp.solution import GaitSolution

    real = GaitSolution.summary
    GaitSolution.summary = lambda self: {**real(self), "stride_length_m": float("nan")}
    try:
        return cli(main, ["generate", "--model", str(model), "--speed", "1.2", "--out", str(tmp / "nan_summary")])
    finally:
        GaitSolution.summary = real


def below_a_file(model: Path, tmp: Path, main: Callable[[list[str]], int]) -> Outcome:
    (tmp / "notes.txt").write_text("a file, not a folder")
    return cli(main, ["generate", "--model", str(model), "--speed", "1.2", "--out", str(tmp / "notes.txt" / "walk")])


def disk_full(model: Path, tmp: Path) -> Outcome:
    """``generate`` in a child process that may not write files larger than 4 kB."""
    script = ("import resource, signal, sys; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
              "resource.setrlimit(resource.RLIMIT_FSIZE, (4096, resource.RLIM_INFINITY)); "
              "from predictive.__main__ import main; sys.exit(main(sys.argv[1:]))")
    proc = subprocess.run([sys.executable, "-c", script, "generate", "--model", str(model), "--speed", "1.2",
                           "--out", str(tmp / "full" / "walk")], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    return Outcome(f"exit {proc.returncode}" + ("" if len(lines) == 1 else f" ({len(lines)} lines)"), lines[-1] if lines else "")


def _written(path: Path, text: str) -> Path:
    """``path`` with ``text`` written to it."""
    path.write_text(text)
    return path


def _load_statistics(tmp: Path, payload: object) -> object:
    from agents.checkpoints import load_statistics

    (tmp / "evil_vecnormalize.pkl").write_bytes(pickle.dumps(payload))
    return load_statistics(tmp / "evil_vecnormalize.pkl")


def _corrupt_stride(tmp: Path) -> Path:
    source = SHARED / "dorschky_P03_walking"
    folder = tmp / "corrupt_stride"
    folder.mkdir(exist_ok=True)
    if not source.exists():
        return folder / "missing"
    (folder / "meta.json").write_text((source / "meta.json").read_text())
    text = (source / "signals.csv").read_text()
    (folder / "signals.csv").write_text(text[:21521] + text[21524:])  # the fuzz-found deletion
    return folder


if __name__ == "__main__":
    main()

"""Virtual subjects of a synthetic dataset: what the estimator is told and their true bodies.

:func:`sample_subjects` draws the subjects of a :class:`~predictive.synth.config.SynthConfig` and
their splits. Height ~ N(1.75 m, 0.08 m) and BMI ~ N(23, 2.5) kg/m² (clipped,
:class:`~predictive.synth.config.SubjectDistribution`); the recordings carry this height and
mass, which is all the estimator is told. The subject's **true** segment parameters deviate from
the generic Winter scaling that the estimator assumes (:func:`perturb_body`,
:class:`~predictive.synth.config.BodyVariation`): segment masses ×(1 ± 10 %) per segment type,
renormalised to the body mass (so the scale reading stays exact); moments of inertia follow the
new mass and length and get a further ×(1 ± 10 %); thigh and shank lengths ×(1 ± 5 %) and the
foot geometry (heel, toe, CoM) ×(1 ± 5 %); CoM shifted along the segment by ± 3 % and across it
by ± 1 % of the segment length; and every leg quantity an extra ± 2 % per side (left/right
asymmetry). All are uniform deviations (half-widths given); combined, a leg segment's mass
deviates by up to about ± 20 % (HAT ± 6 %) and, through mass × length² × its own factor, its
inertia by up to about ± 45 % (extremes of 2,000 draws; the per-parameter deviations of every
subject are in ``dataset.json``, ``info.subjects.<id>.body_deviation``, :func:`body_deviation`).
These spreads are design choices of the order of the differences between published
anthropometric tables (e.g. thigh mass 10.0 % of body mass in Dempster/Winter but 14.2 % in
de Leva 1996, J Biomech 29:1223–1230; CoM positions differing by a few % of the segment length)
and of the prediction errors of such tables for individuals that the body-segment-parameter
literature reports (reviewed by Pearsall & Reid 1994, Sports Med 18:126–140); they are not
fitted to a particular study.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from predictive.synth.config import BodyVariation, SynthConfig
from sspinn.model.body import BodyParameters, Foot, Segment
from sspinn.model.conventions import SEGMENTS, SIDES


@dataclass(frozen=True)
class VirtualSubject:
    """A virtual subject: what the estimator is told (height m, mass kg) and the true body."""

    id: str
    index: int
    split: str
    height: float
    mass: float
    body: BodyParameters

    @property
    def nominal_body(self) -> BodyParameters:
        """The generic Winter-scaled body the estimator assumes."""
        return BodyParameters.from_anthropometry(self.height, self.mass)


def sample_subjects(config: SynthConfig) -> list[VirtualSubject]:
    """The virtual subjects of ``config`` with their splits (deterministic by seed).

    The splits are stratified by each subject's first program and pace (subject i starts with
    program i mod P at pace (i // P) mod K, :meth:`~predictive.synth.config.SynthConfig.pace`, so
    its cell is i mod P·K): the subjects of each cell are shuffled and interleaved (cells in a
    random order), and the test, val and train splits take their shares from that sequence in
    turn, so every split of P·K or more subjects holds every program at every pace when it can.
    With one pace (K = 1) the cells are the programs.
    """
    d = config.subjects
    rng = config.rng(0)
    n_cells = len(config.programs) * len(config.paces)
    groups = [list(rng.permutation(np.arange(c, config.n_subjects, n_cells))) for c in rng.permutation(n_cells)]
    order = [int(g[k]) for k in range(max(len(g) for g in groups)) for g in groups if k < len(g)]
    split_of: dict[int, str] = {}
    start = 0
    for split in ("test", "val", "train"):
        for i in order[start : start + config.splits.get(split, 0)]:
            split_of[i] = split
        start += config.splits.get(split, 0)
    subjects = []
    for i in range(config.n_subjects):
        rng = config.rng(1, i)
        height = float(np.clip(rng.normal(d.height_mean, d.height_sd), *d.height_range))
        bmi = float(np.clip(rng.normal(d.bmi_mean, d.bmi_sd), *d.bmi_range))
        height, mass = round(height, 3), round(bmi * height**2, 2)
        body = perturb_body(height, mass, config.body_variation, rng)
        subjects.append(VirtualSubject(f"{config.name}_S{i + 1:02d}", i, split_of[i], height, mass, body))
    return subjects


def perturb_body(height: float, mass: float, variation: BodyVariation, rng: np.random.Generator) -> BodyParameters:
    """True body parameters: the Winter scaling of ``height`` (m) and ``mass`` (kg) with random
    deviations of the half-widths in ``variation`` (see the module docstring); the segment masses
    add up to ``mass`` exactly."""
    nominal = BodyParameters.from_anthropometry(height, mass)
    v = variation

    def u(half_width: float, size: int | None = None) -> Any:
        return rng.uniform(-half_width, half_width, size)

    kinds = ("pelvis", "femur", "tibia", "foot")
    f_mass = {k: 1 + u(v.mass) for k in kinds}
    f_inertia = {k: 1 + u(v.inertia) for k in kinds}
    f_length = {"pelvis": 1.0, "femur": 1 + u(v.length), "tibia": 1 + u(v.length), "foot": 1 + u(v.foot)}
    along = {k: u(v.com_along) for k in kinds}
    across = {k: u(v.com_across) for k in kinds}
    side = {(k, s): 1 + u(v.asymmetry) for k in kinds[1:] for s in SIDES}
    raw_mass = {"pelvis": nominal.pelvis.mass * f_mass["pelvis"]}
    for s in SIDES:
        for k in kinds[1:]:
            raw_mass[f"{k}_{s}"] = getattr(nominal, f"{k}_{s}").mass * f_mass[k] * side[(k, s)]
    scale = mass / sum(raw_mass.values())
    segments: dict[str, Segment] = {}
    for name in SEGMENTS:
        kind = name.split("_")[0]
        seg = getattr(nominal, name)
        fl = f_length[kind] * (side[(kind, name[-1])] if kind != "pelvis" else 1.0)
        new_mass = raw_mass[name] * scale
        inertia = seg.inertia * (new_mass / seg.mass) * fl**2 * f_inertia[kind]
        length = seg.length * fl
        if isinstance(seg, Foot):
            com = (seg.com[0] * fl + across[kind] * length, seg.com[1] * fl + along[kind] * length)
            heel = (seg.heel[0] * fl, seg.heel[1] * fl)
            toe = (seg.toe[0] * fl, seg.toe[1] * fl)
            segments[name] = Foot(mass=new_mass, inertia=inertia, com=com, length=length, heel=heel, toe=toe)
        else:
            sign = 1.0 if kind == "pelvis" else -1.0
            com = (seg.com[0] + across[kind] * length, seg.com[1] * fl + sign * along[kind] * length)
            segments[name] = Segment(mass=new_mass, inertia=inertia, com=com, length=length)
    return nominal.replace(**segments)


def body_deviation(true: BodyParameters, nominal: BodyParameters) -> dict[str, float]:
    """Relative deviation (true/nominal − 1) of each nonzero body parameter, for reports."""
    from sspinn.model.body import PARAMETERS

    t, n = true.vector(), nominal.vector()
    return {name: float(a / b - 1) for name, a, b in zip(PARAMETERS, t, n) if abs(b) > 1e-12}

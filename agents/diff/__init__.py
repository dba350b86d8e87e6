"""Controllers learned through the differentiable simulator: APG, SHAC and AHAC
(:mod:`agents.diff.agent`), their settings (:mod:`agents.diff.settings`) and their training runs
(:mod:`agents.diff.train`). See docs/diff_controller.md."""

from agents.config import DIFF_ALGORITHMS
from agents.diff.agent import DiffAgent
from agents.diff.settings import DiffSettings

__all__ = ["DIFF_ALGORITHMS", "DiffAgent", "DiffSettings"]

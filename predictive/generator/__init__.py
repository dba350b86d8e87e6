"""Gait generation without trajectory optimisation, and closed-loop deployment of gait cycles.

* :mod:`~predictive.generator.gait_generator` — the self-supervised gait generator (one network,
  (speed, height, mass) → a periodic gait cycle);
* :mod:`~predictive.generator.closed_loop` — feedforward + periodic LQR tracking of any gait
  cycle (generator or OCP) in the Gymnasium environment;
* :mod:`~predictive.generator.cli` — ``python -m predictive train-generator`` and ``generate``.
"""

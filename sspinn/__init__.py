"""sspinn: self-supervised physics-informed estimation of sagittal gait from IMUs, and
predictive gait simulation, on one Kane-derived 9-DOF model.

Start with :mod:`sspinn.conventions` (units, signs, frames, orders), :mod:`sspinn.body`
(parameters), :mod:`sspinn.dynamics` (equations of motion for NumPy / torch / CasADi),
:mod:`sspinn.kinematics` (points, segments, virtual IMUs) and :mod:`sspinn.simulation`.
"""

__version__ = "0.1.0"

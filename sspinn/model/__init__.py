"""The body model and its backends: one sagittal 9-DOF multibody model, derived once.

:mod:`~sspinn.model.conventions` (units, signs, frames, orders), :mod:`~sspinn.model.body`
(parameters), :mod:`~sspinn.model.contact` and :mod:`~sspinn.model.passive` (forces),
:mod:`~sspinn.model.derivation` (SymPy's Kane's method) → :mod:`~sspinn.model.codegen` →
``_generated`` (NumPy/torch/CasADi expressions and numba kernels), :mod:`~sspinn.model.backends`
(array namespaces), :mod:`~sspinn.model.dynamics` and :mod:`~sspinn.model.kinematics` (the public
model API), :mod:`~sspinn.model.integrators` and :mod:`~sspinn.model.simulation` (stepping),
:mod:`~sspinn.model.trajectory` (the one motion type and its Kane residual),
:mod:`~sspinn.model.drawing` (stick figures) and :mod:`~sspinn.model.showcase` (a drop landing).
"""

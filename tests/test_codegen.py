"""The committed generated backends are exactly what the derivation produces today."""

from __future__ import annotations

from sspinn.model import codegen


def test_generated_files_are_up_to_date():
    for path, text in codegen.generate_all().items():
        committed = path.read_text()
        assert committed == text, f"{path} is stale: run `make generate` (python -m sspinn.model.codegen)"


def test_generated_functions_match_specs():
    from sspinn.model._generated import model_expr

    for name in codegen.EXPR_FUNCTIONS:
        assert callable(getattr(model_expr, name))


def test_mass_matrix_solver_is_exact_on_the_model_sparsity_pattern():
    """The generated unrolled L·D·Lᵀ solve equals a dense solve on matrices with the mass matrix's
    structural zeros (random SPD, well and badly scaled), and its elimination order creates no
    fill beyond the (pelvis_tx, pelvis_ty) entry."""
    import numpy as np

    from sspinn.model._generated import model_numba
    from sspinn.model.derivation import derive

    pattern = derive().outputs["mass_matrix"]
    zero = np.array([[pattern[i, j] == 0 for j in range(9)] for i in range(9)])
    assert zero[0, 1] and zero[3, 6] and not zero[3, 4]
    order = codegen.elimination_order(pattern)
    fill = {(min(p, a), max(p, a)) for p, rows in order for a in rows if zero[p, a]}
    assert fill == {(0, 1)}
    rng = np.random.default_rng(0)
    for scale in (1.0, 1e-3, 1e3):
        a = rng.normal(size=(9, 9))
        m = a @ a.T + 9 * np.eye(9)
        m[zero] = 0.0
        m = m + 20 * np.eye(9)  # keep it positive definite after zeroing
        m *= scale
        f = rng.normal(size=9)
        out = np.empty(9)
        model_numba.solve_mass_matrix(m, f, out)
        np.testing.assert_allclose(out, np.linalg.solve(m, f), rtol=1e-12, atol=0)

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

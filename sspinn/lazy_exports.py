"""Public names of a package, imported on first use (PEP 562 module ``__getattr__``).

Each package's ``__init__`` lists its public names in ``__all__`` and maps each to the module
that defines it; :func:`attach` gives the ``__getattr__`` and ``__dir__`` that import that module
when the name is first read, so that ``import sspinn`` (and every package that uses this helper) stays fast and
imports neither torch nor CasADi. A name that maps to ``<package>.<name>`` is that sub-module;
``"module:attribute"`` exports the attribute under another name (a public name must not be the
name of a sub-module: importing the sub-module would replace it on the package).

Why by hand: ``lazy_loader`` (scientific-python) does the same in about as many lines but would be
one more dependency for these few.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from importlib import import_module
from typing import Any


def attach(package: str, exports: Mapping[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for the package ``package`` whose public names are ``exports``
    (name → the module defining it)."""

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        if module == f"{package}.{name}":
            return import_module(module)
        module, _, attribute = module.partition(":")
        return getattr(import_module(module), attribute or name)

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return __getattr__, __dir__

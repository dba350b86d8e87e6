"""Build the HTML API reference of the project's packages with pdoc (``make docs``).

pdoc documents a package's submodules only when they are named, and a package whose ``__all__``
exports names lazily (``sspinn``'s module ``__getattr__``) shows them only once they are
attributes. So this script names every public module of ``sspinn``, ``envs``, ``agents`` and
``predictive`` (modules whose dotted name has a part starting with ``_``, such as
``sspinn.model._generated`` and the ``__main__`` entry points, are left out: importing a
``__main__`` would run its command) and resolves the lazy exports before handing them to pdoc.
Importing the modules runs no training, generation or compilation.

Usage: ``python scripts/build_api_docs.py [--out docs/api]`` (needs the ``docs`` extra: pdoc).
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from pathlib import Path

PACKAGES = ("sspinn", "envs", "agents", "predictive")


def public_modules(packages: tuple[str, ...] = PACKAGES) -> list[str]:
    """Dotted names of every module of ``packages`` with no part starting with ``_``, sorted."""
    names: list[str] = []
    for package in packages:
        module = importlib.import_module(package)
        names.append(package)
        for info in pkgutil.walk_packages(module.__path__, prefix=f"{package}."):
            if not any(part.startswith("_") for part in info.name.split(".")):
                names.append(info.name)
    return sorted(names)


def pdoc_arguments(modules: list[str]) -> list[str]:
    """The fewest of ``modules`` that make pdoc document all of them.

    pdoc documents a named package's submodules itself, those in its ``__all__`` when it has one,
    else every public one; naming a module twice warns. A module is named here only when no
    module named before reaches it that way.
    """

    def reaches(package: str, module: str) -> bool:
        parts = module.split(".")
        for depth in range(package.count(".") + 1, len(parts)):
            parent = importlib.import_module(".".join(parts[:depth]))
            exported = getattr(parent, "__all__", None)
            if exported is not None and parts[depth] not in exported:
                return False
        return True

    named: list[str] = []
    for module in sorted(modules):
        if not any(module.startswith(f"{p}.") and reaches(p, module) for p in named):
            named.append(module)
    return named


def resolve_lazy_exports(package: str) -> None:
    """Make each name of ``package.__all__`` an attribute of the package (for pdoc's listing)."""
    module = importlib.import_module(package)
    for name in getattr(module, "__all__", ()):
        if name not in vars(module):
            setattr(module, name, getattr(module, name))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/api", help="output folder (default: docs/api)")
    args = parser.parse_args(argv)
    try:
        import pdoc
    except ImportError:
        print("error: pdoc is not installed; install the docs extra: pip install -e '.[docs]'", file=sys.stderr)
        return 2
    for package in PACKAGES:
        resolve_lazy_exports(package)
    modules = public_modules()
    pdoc.pdoc(*pdoc_arguments(modules), output_directory=Path(args.out))
    print(f"{len(modules)} modules documented in {Path(args.out) / 'index.html'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

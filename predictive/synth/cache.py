"""The synthetic-data caches: keys, ``CODE_VERSION`` and the files under ``cache_dir``.

Periodic solutions, chains and finished recordings are cached by a hash of everything that
determines them (:func:`stable_hash` of the body, the plans, the settings, the guesses' keys and
:data:`CODE_VERSION`), so a second run of the same configuration only reads files. The files are
plain ``.npz``/``.json``/``.csv`` (:meth:`GaitSolution.save`, :meth:`ChainResult.save`,
:meth:`Recording.save`), no pickles: they do not depend on the module layout.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, TypeVar

import numpy as np

from predictive.ocp.solution import GaitSolution
from predictive.synth.chain import ChainResult
from sspinn.data.dataset import Recording

T = TypeVar("T")

#: Bump when the generator's output for the same configuration changes (invalidates the caches).
CODE_VERSION: Final = 4

#: The generator's name in the files it writes (``provenance.generator`` of every recording,
#: ``info.generator`` of ``dataset.json``; the output folder check of ``predictive synth``): the
#: module's name before it was split into :mod:`predictive.synth`, kept so that cached
#: recordings and earlier datasets stay valid without a new :data:`CODE_VERSION`.
GENERATOR_NAME: Final = "predictive.synthetic"


def jsonable(obj: Any) -> Any:
    """Tuples → lists, numpy → Python, inf → "inf" (strict JSON)."""
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [jsonable(v) for v in obj.tolist()]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    return obj


def stable_hash(obj: Any) -> str:
    """The cache key of ``obj``: SHA-256 (20 hex digits) of its canonical JSON (:func:`jsonable`,
    sorted keys), so it depends on the values only, not on dict order or Python objects."""
    text = json.dumps(jsonable(obj), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


@dataclass
class CacheStats:
    """Hits and misses of the caches during one generation."""

    periodic_hits: int = 0
    periodic_solved: int = 0
    chain_hits: int = 0
    chain_solved: int = 0
    recording_hits: int = 0
    recording_made: int = 0

    def add(self, other: CacheStats) -> None:
        for f in dataclasses.fields(self):
            setattr(self, f.name, getattr(self, f.name) + getattr(other, f.name))


class SynthCache:
    """Files under ``root``: ``periodic/<key>.npz|json`` (GaitSolution), ``chains/<key>.npz``
    (ChainResult), ``recordings/<key>/<name>.csv|json`` (Recording)."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.stats = CacheStats()

    def periodic(self, key: str, solve: Callable[[], GaitSolution]) -> GaitSolution:
        path = self.root / "periodic" / key
        present = all(path.with_name(key + ext).exists() for ext in (".npz", ".json"))
        return self._load_or_solve("periodic", present, lambda: GaitSolution.load(path), solve, lambda s: s.save(path))

    def chain(self, key: str, solve: Callable[[], ChainResult]) -> ChainResult:
        path = self.root / "chains" / f"{key}.npz"
        return self._load_or_solve("chain", path.exists(), lambda: ChainResult.load(path), solve, lambda c: c.save(path))

    def _load_or_solve(self, kind: str, present: bool, load: Callable[[], T], solve: Callable[[], T], save: Callable[[T], object]) -> T:
        """The cached ``kind`` (counted as a hit) or a fresh solution, saved (counted as solved)."""
        value = load() if present else solve()
        if not present:
            save(value)
        counter = f"{kind}_hits" if present else f"{kind}_solved"
        setattr(self.stats, counter, getattr(self.stats, counter) + 1)
        return value

    def recording(self, key: str, name: str, make: Callable[[], Recording]) -> Recording:
        folder = self.root / "recordings" / key
        if (folder / f"{name}.csv").exists() and (folder / f"{name}.json").exists():
            self.stats.recording_hits += 1
            return Recording.load(folder / f"{name}.csv")
        rec = make()
        tmp = folder.with_name(key + ".tmp")
        shutil.rmtree(tmp, ignore_errors=True)
        rec.save(tmp)
        shutil.rmtree(folder, ignore_errors=True)
        tmp.replace(folder)
        self.stats.recording_made += 1
        # what the dataset gets is exactly what a cache hit would return (CSV precision)
        return Recording.load(folder / f"{name}.csv")

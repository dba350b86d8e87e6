"""Recordings from every on-disk form the project reads, through one call: :func:`open_recordings`
(and a whole dataset folder: :func:`dataset_recordings`)."""

from __future__ import annotations

from pathlib import Path

from sspinn.data.csv_readers import read_averaged_stride
from sspinn.data.dataset import DataFormatError, Dataset, Recording


def open_recordings(
    path: str | Path, split: str = "train", periods: int = 10, height: float = 1.75, mass: float = 70.0,
) -> list[Recording]:
    """The recordings at ``path``:

    * a dataset folder (with ``dataset.json``): the recordings of one ``split``;
    * a folder with one averaged stride (``signals.csv`` + ``meta.json``): the stride resampled to
      100 Hz and repeated ``periods`` times (the paper's circular padding), for a subject of
      ``height`` m and ``mass`` kg when ``meta.json`` gives none;
    * a recording ``.csv`` with its JSON sidecar.

    Raises :class:`~sspinn.data.dataset.DataFormatError` naming the path otherwise."""
    path = Path(path)
    if (path / "dataset.json").exists():
        return Dataset.open(path).load(split)
    if (path / "signals.csv").exists() and (path / "meta.json").exists():
        return [read_averaged_stride(path, height=height, mass=mass, periods=periods)]
    if path.suffix == ".csv":
        return [Recording.load(path)]
    raise DataFormatError(f"{path}: not a dataset folder (dataset.json), an averaged-stride folder (signals.csv + meta.json) or a recording .csv")


def dataset_recordings(path: str | Path) -> list[Recording]:
    """Every recording of every split of the dataset folder at ``path`` (each once), or none
    when ``path`` is not a dataset folder (an averaged stride or a recording file)."""
    path = Path(path)
    if not (path / "dataset.json").exists():
        return []
    dataset = Dataset.open(path)
    unique = {rec.name: rec for split in dataset.splits for rec in dataset.load(split)}
    return list(unique.values())


def labelled_recordings(path: str | Path, split: str, group: str = "grf") -> list[Recording]:
    """The recordings of ``split`` at ``path`` (as :func:`open_recordings`), each with the label
    group ``group`` (a :class:`~sspinn.data.dataset.Labels` field, e.g. ``"grf"``); raises
    :class:`~sspinn.data.dataset.DataFormatError` naming the path and the first recording
    without it, or saying that the split is empty."""
    recordings = open_recordings(path, split)
    if not recordings:
        raise DataFormatError(f"{path} ({split}): no recordings")
    for rec in recordings:
        if rec.labels is None or getattr(rec.labels, group) is None:
            raise DataFormatError(f"{path} ({split}): recording {rec.name} has no {group} labels, which this needs")
    return recordings

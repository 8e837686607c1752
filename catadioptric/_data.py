"""The package data (``catadioptric/data``): the scene specs, the rig spec files and the
renderers' quality and resolution presets. Read through :mod:`importlib.resources`, so that
they come with every installation (wheel, ``pip install .``, editable checkout); the
top-level ``scenes/`` and ``render/`` folders of a checkout are for what users edit and
for outputs (``docs/formats.md``, "Where the files live")."""
from __future__ import annotations

from importlib import resources
from pathlib import Path

from ._checks import CatadioptricError

__all__ = ["data_path", "data_names"]


def data_path(*parts: str) -> Path:
    """A file or folder of the package data as a file-system path (it may not exist)."""
    ref = resources.files(__package__).joinpath("data", *parts)
    if not isinstance(ref, Path):  # pragma: no cover - a zipped installation, which pip never makes
        raise CatadioptricError(f"catadioptric: the package data must be on the file system, got {ref!r}")
    return ref


def data_names(folder: str, suffixes=(".toml", ".json")) -> list[str]:
    """The names (file stems) of the spec files in the package data folder ``folder``."""
    d = data_path(folder)
    if not d.is_dir():
        return []
    return sorted(p.stem for p in d.iterdir() if p.suffix in suffixes and p.is_file())

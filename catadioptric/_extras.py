"""Optional dependencies: which extra of ``pip install 'catadioptric[...]'`` brings each module,
and the one-line error a missing one gives (``pyproject.toml`` lists the extras)."""
from __future__ import annotations

import importlib

from ._checks import CatadioptricError

__all__ = ["EXTRAS", "MissingExtraError", "require", "missing_extra"]

#: top-level module -> (the package pip installs, the extra that brings it)
EXTRAS = {
    "matplotlib": ("matplotlib", "plot"),
    "cv2": ("opencv-contrib-python-headless", "opencv"),
    "trimesh": ("trimesh", "scenes"),
    "shapely": ("shapely", "scenes"),
    "mapbox_earcut": ("mapbox-earcut", "scenes"),
    "tqdm": ("tqdm", "render"),
    "numba": ("numba", "render"),
    "mitsuba": ("mitsuba", "mitsuba"),
    "drjit": ("mitsuba", "mitsuba"),
    "dask": ("dask[distributed]", "dask"),
    "distributed": ("dask[distributed]", "dask"),
    "poselib": ("poselib", "peers"),
}


class MissingExtraError(CatadioptricError, ImportError):
    """An optional dependency is not installed; the message names the extra that brings it.
    A :class:`CatadioptricError` (the command prints it in one line) and an ``ImportError``."""

    def __init__(self, message: str, name: str | None = None):
        ImportError.__init__(self, message, name=name)


def _message(module: str, what: str | None) -> str:
    top = module.split(".")[0]
    package, extra = EXTRAS.get(top, (top, None))
    need = f"{what} needs {package}" if what else f"{package} is not installed"
    if extra is None:
        return f"{need}: pip install {package}"
    return f"{need} (extra {extra!r}): pip install 'catadioptric[{extra}]'"


def require(module: str, what: str | None = None):
    """Import and return ``module``; when it is missing raise :class:`MissingExtraError` naming the
    extra to install (``what`` says what needs it: ``"catadioptric centrality"``)."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name is None or exc.name.split(".")[0] != module.split(".")[0]:
            raise  # the module is there but one of its own dependencies is not: a real error
        raise MissingExtraError(_message(module, what), name=exc.name) from None


def missing_extra(exc: BaseException) -> MissingExtraError | None:
    """The :class:`MissingExtraError` for a ``ModuleNotFoundError`` of an optional dependency, else None."""
    if isinstance(exc, MissingExtraError):
        return exc
    if isinstance(exc, ModuleNotFoundError) and exc.name and exc.name.split(".")[0] in EXTRAS:
        return MissingExtraError(_message(exc.name, None), name=exc.name)
    return None

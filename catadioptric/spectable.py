"""Spec tables: the checked reader of the project's small TOML / JSON spec files (rig specs,
:mod:`catadioptric.rigspec`; scene specs, :mod:`catadioptric.scenes`; benchmark specs,
:mod:`catadioptric.validate.benchmark_spec`).

:func:`read_spec_file` parses a file; :class:`SpecTable` reads one table of it, checks every
value and refuses unknown keys. Every error is a :class:`CatadioptricError` whose message starts
with the key's full path (``rig.mirror.a: expected a positive number, got -0.03``).
"""
from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping
from pathlib import Path

from ._checks import CatadioptricError

__all__ = ["REQUIRED", "SpecTable", "read_spec_file", "show"]


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


#: Default marker of a key that must be present.
REQUIRED = _Required()


def show(value, limit: int = 80) -> str:
    """A short description of a parsed value for an error message."""
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, list) and value and all(isinstance(v, Mapping) for v in value):
        return "an array of tables"
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _interval_text(lo, hi, lo_open, hi_open) -> str:
    if lo == 0 and lo_open and hi is None:
        return "a positive number"
    if lo == 0 and not lo_open and hi is None:
        return "a number >= 0"
    if lo is not None and hi is None:
        return f"a number {'>' if lo_open else '>='} {lo!r}"
    if lo is None and hi is not None:
        return f"a number {'<' if hi_open else '<='} {hi!r}"
    if lo is not None and hi is not None:
        return f"a number in {'(' if lo_open else '['}{lo!r}, {hi!r}{')' if hi_open else ']'}"
    return "a number"


def _in_interval(x: float, lo, hi, lo_open, hi_open) -> bool:
    if lo is not None and (x <= lo if lo_open else x < lo):
        return False
    if hi is not None and (x >= hi if hi_open else x > hi):
        return False
    return True


class SpecTable:
    """Checked access to one table of a parsed TOML/JSON spec.

    Each accessor reads one key, checks its type and value, records the
    (normalised) value for :meth:`done` and returns it. A key absent from the
    file takes its ``default``; ``default=REQUIRED`` makes it mandatory and
    ``default=None`` makes it optional (absent keys then stay absent from the
    normalised table). :meth:`done` refuses keys no accessor asked for and
    returns the normalised table (plain Python values, sub-tables included),
    which reads back to itself.
    """

    def __init__(self, data, path: str):
        if not isinstance(data, Mapping):
            raise CatadioptricError(f"{path}: expected a table, got {show(data)}")
        self._data = dict(data)
        self.path = path
        self._out: dict = {}
        self._known: list[str] = []

    # ------------------------------------------------------------------ helpers
    def key_path(self, key: str) -> str:
        """The full path of ``key`` in this table (``scene.buildings.height_range``)."""
        return f"{self.path}.{key}" if self.path else key

    def error(self, key: str, message: str) -> CatadioptricError:
        """A :class:`CatadioptricError` about ``key`` (message after the key's path)."""
        return CatadioptricError(f"{self.key_path(key)}: {message}")

    def has(self, key: str) -> bool:
        """True when the file gives ``key``."""
        return key in self._data

    def raw(self, key: str, default=None):
        """The value of ``key`` as parsed, unchecked (for dispatch on its type)."""
        return self._data.get(key, default)

    def _fetch(self, key: str, default, what: str):
        if key not in self._known:
            self._known.append(key)
        if key in self._data:
            return self._data[key], True
        if default is REQUIRED:
            raise self.error(key, f"missing; expected {what}")
        return default, False

    def _fail(self, key: str, what: str, value):
        raise self.error(key, f"expected {what}, got {show(value)}")

    def _store(self, key, value):
        if value is not None:
            self._out[key] = value
        return value

    def exclusive(self, *keys: str) -> None:
        """Refuse a table that gives more than one of ``keys``."""
        given = [k for k in keys if k in self._data]
        if len(given) > 1:
            raise CatadioptricError(
                f"{self.path}: give one of {', '.join(keys)}, not several (got {', '.join(given)})")

    # ---------------------------------------------------------------- scalars
    def number(self, key: str, default=REQUIRED, *, min=None, max=None, min_open=False, max_open=False,
               positive=False, nonnegative=False, what: str | None = None) -> float | None:
        """A real number (TOML integer or float), optionally bounded."""
        if positive:
            min, min_open = 0.0, True
        if nonnegative:
            min, min_open = 0.0, False
        what = what or _interval_text(min, max, min_open, max_open)
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        if not _is_number(v) or not math.isfinite(v) or not _in_interval(float(v), min, max, min_open, max_open):
            self._fail(key, what, v)
        return self._store(key, float(v))

    def integer(self, key: str, default=REQUIRED, *, min=None, max=None) -> int | None:
        """An integer (TOML integer, not a float), optionally bounded."""
        if min is not None and max is None:
            what = f"an integer >= {min}"
        elif min is not None:
            what = f"an integer in [{min}, {max}]"
        else:
            what = "an integer"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        if not isinstance(v, int) or isinstance(v, bool) or not _in_interval(v, min, max, False, False):
            self._fail(key, what, v)
        return self._store(key, int(v))

    def boolean(self, key: str, default=REQUIRED) -> bool | None:
        v, given = self._fetch(key, default, "true or false")
        if v is None:
            return None
        if not isinstance(v, bool):
            self._fail(key, "true or false", v)
        return self._store(key, v)

    def string(self, key: str, default=REQUIRED, *, choices=None) -> str | None:
        what = "a string" if choices is None else "one of " + ", ".join(repr(c) for c in choices)
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        if not isinstance(v, str) or (choices is not None and v not in choices):
            self._fail(key, what, v)
        return self._store(key, v)

    # ------------------------------------------------------------------ lists
    def strings(self, key: str, default=REQUIRED, *, choices=None) -> list[str] | None:
        """A non-empty list of strings (each among ``choices`` when given)."""
        what = "a non-empty list of strings" + ("" if choices is None else " among " + ", ".join(map(repr, choices)))
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) >= 1 and all(isinstance(x, str) for x in v)
        ok = ok and (choices is None or all(x in choices for x in v))
        if not ok:
            self._fail(key, what, v)
        return self._store(key, list(v))

    def numbers(self, key: str, default=REQUIRED, *, length=None, min_length=1, min=None, max=None,
                min_open=False, max_open=False, positive=False, nonnegative=False,
                what: str | None = None) -> list[float] | None:
        """A list of real numbers (``length`` of them, or at least ``min_length``)."""
        if positive:
            min, min_open = 0.0, True
        if nonnegative:
            min, min_open = 0.0, False
        if what is None:
            each = _interval_text(min, max, min_open, max_open)
            each = "numbers" if each == "a number" else each.replace("a number", "numbers", 1).replace(
                "a positive number", "positive numbers")
            count = f"{length}" if length is not None else f"at least {min_length}"
            what = f"a list of {count} {each}"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and all(_is_number(x) and math.isfinite(x) for x in v)
        ok = ok and (len(v) == length if length is not None else len(v) >= min_length)
        ok = ok and all(_in_interval(float(x), min, max, min_open, max_open) for x in v)
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [float(x) for x in v])

    def integers(self, key: str, default=REQUIRED, *, length: int, min=None) -> list[int] | None:
        """A list of ``length`` integers (each ``>= min`` when given)."""
        what = f"a list of {length} integers" + (f" >= {min}" if min is not None else "")
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) == length
        ok = ok and all(isinstance(x, int) and not isinstance(x, bool) and (min is None or x >= min) for x in v)
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [int(x) for x in v])

    def vector(self, key: str, default=REQUIRED, n: int = 3) -> list[float] | None:
        """``n`` real numbers (a point or a direction)."""
        return self.numbers(key, default, length=n, what=f"a list of {n} numbers")

    def range(self, key: str, default=REQUIRED, *, nonnegative: bool = False) -> list[float] | None:
        """``[low, high]`` with ``0 < low <= high`` (``0 <= low`` when ``nonnegative``)."""
        what = "two increasing non-negative numbers" if nonnegative else "two increasing positive numbers"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) == 2 and all(_is_number(x) and math.isfinite(x) for x in v)
        if ok:
            lo, hi = float(v[0]), float(v[1])
            ok = (lo >= 0 if nonnegative else lo > 0) and lo <= hi
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [float(v[0]), float(v[1])])

    def color(self, key: str, default=REQUIRED) -> list[float] | None:
        """An RGB colour: three numbers in [0, 1]."""
        return self.numbers(key, default, length=3, min=0.0, max=1.0, what="an RGB colour: three numbers in [0, 1]")

    def colors(self, key: str, default=REQUIRED) -> list[list[float]] | None:
        """A non-empty list of RGB colours."""
        what = "a non-empty list of RGB colours (three numbers in [0, 1] each)"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) >= 1
        ok = ok and all(isinstance(c, (list, tuple)) and len(c) == 3 and
                        all(_is_number(x) and 0 <= x <= 1 for x in c) for c in v)
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [[float(x) for x in c] for c in v])

    def matrix(self, key: str, default=REQUIRED, rows: int = 3, cols: int = 3) -> list[list[float]] | None:
        """A ``rows`` x ``cols`` matrix as a list of rows."""
        what = f"a {rows}x{cols} matrix (a list of {rows} rows of {cols} numbers)"
        v, given = self._fetch(key, default, what)
        if v is None:
            return None
        ok = isinstance(v, (list, tuple)) and len(v) == rows
        ok = ok and all(isinstance(r, (list, tuple)) and len(r) == cols and
                        all(_is_number(x) and math.isfinite(x) for x in r) for r in v)
        if not ok:
            self._fail(key, what, v)
        return self._store(key, [[float(x) for x in r] for r in v])

    def weights(self, key: str, default, names) -> dict[str, float]:
        """A table ``{name: weight}`` over some of ``names``: weights >= 0, at least one positive."""
        what = f"a table of weights >= 0 over {', '.join(names)} with at least one positive weight"
        v, given = self._fetch(key, default, what)
        if not isinstance(v, Mapping):
            self._fail(key, what, v)
        for name, w in v.items():
            if name not in names:
                raise self.error(f"{key}.{name}", f"unknown key; expected one of {', '.join(names)}")
            if not _is_number(w) or not math.isfinite(w) or w < 0:
                raise self.error(f"{key}.{name}", f"expected a weight >= 0, got {show(w)}")
        if not any(w > 0 for w in v.values()):
            self._fail(key, what, dict(v))
        return self._store(key, {name: float(v[name]) for name in names if name in v})

    # ----------------------------------------------------------------- tables
    def table(self, key: str, required: bool = False) -> "SpecTable":
        """The sub-table ``key`` (empty when absent and not ``required``)."""
        v, given = self._fetch(key, REQUIRED if required else {}, "a table")
        sub = SpecTable(v, self.key_path(key))
        self._out[key] = sub
        return sub

    def tables(self, key: str, *, min_count: int = 0) -> list["SpecTable"]:
        """The array of tables ``key`` (TOML ``[[key]]``), at least ``min_count`` of them."""
        what = f"an array of tables ([[{key}]])" + (f" with at least {min_count}" if min_count else "")
        v, given = self._fetch(key, REQUIRED if min_count else [], what)
        if not isinstance(v, (list, tuple)) or len(v) < min_count:
            self._fail(key, what, v)
        subs = [SpecTable(item, f"{self.key_path(key)}[{i}]") for i, item in enumerate(v)]
        self._out[key] = subs
        return subs

    def nested(self, key: str, reader, default=None):
        """Read the sub-table ``key`` with ``reader(value, path) -> normalised dict`` (another
        spec's reader, e.g. :func:`read_rig_spec` for a rig inlined in a scene spec)."""
        v, given = self._fetch(key, default, "a table")
        if v is None:
            return None
        return self._store(key, reader(v, self.key_path(key)))

    def done(self) -> dict:
        """Refuse unknown keys; return the normalised table (sub-tables resolved)."""
        unknown = [k for k in self._data if k not in self._known]
        if unknown:
            raise self.error(unknown[0], f"unknown key; expected one of {', '.join(self._known)}")
        out = {}
        for k, v in self._out.items():
            if isinstance(v, SpecTable):
                out[k] = v.done()
            elif isinstance(v, list) and v and isinstance(v[0], SpecTable):
                out[k] = [s.done() for s in v]
            else:
                out[k] = v
        return out


# ------------------------------------------------------------------ spec files
def read_spec_file(path) -> dict:
    """Parse a ``.toml`` or ``.json`` spec file; syntax errors name the file."""
    p = Path(path)
    try:
        text = p.read_bytes()
    except OSError as exc:
        raise CatadioptricError(f"path: cannot read spec file {str(p)!r} ({exc.strerror})") from None
    try:
        if p.suffix.lower() == ".json":
            data = json.loads(text.decode("utf-8"))
        else:
            data = tomllib.loads(text.decode("utf-8"))
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise CatadioptricError(f"path: {str(p)!r} is not a valid {p.suffix.lstrip('.').upper() or 'TOML'} file: {exc}") from None
    if not isinstance(data, dict):
        raise CatadioptricError(f"path: {str(p)!r} must hold a table at its top level, got {show(data)}")
    return data

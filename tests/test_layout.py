"""The package's structure: no private name crosses a module boundary, imports point downward, and
no function takes more than 15 parameters.

Both checks read the source with :mod:`ast` (nothing is imported), so they see imports made
inside functions as well as at import time.
"""
from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = "catadioptric"
ROOT = Path(__file__).resolve().parents[1] / PACKAGE


def _modules():
    """``{dotted name: path}`` for every module of the package (a package is its ``__init__``)."""
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _is_package(name):
    return MODULES[name].name == "__init__.py"


def _resolve(module, level, target):
    """The absolute name of ``from <level dots><target> import ...`` written in ``module``."""
    if level == 0:
        return target
    base = module.split(".") if _is_package(module) else module.split(".")[:-1]
    base = base[:len(base) - (level - 1)]
    return ".".join(base + ([target] if target else []))


def _private(name):
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _inside(name):
    return name == PACKAGE or name.startswith(PACKAGE + ".")


def _type_checking(node):
    """``if TYPE_CHECKING:`` (or ``typing.TYPE_CHECKING``): imports for annotations only."""
    if not isinstance(node, ast.If):
        return False
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (isinstance(t, ast.Attribute)
                                                                     and t.attr == "TYPE_CHECKING")


def _runtime_nodes(tree):
    """Every node of ``tree`` except the bodies of ``if TYPE_CHECKING:`` blocks."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        if _type_checking(node):
            todo.extend(node.orelse)
            continue
        todo.extend(ast.iter_child_nodes(node))


def _imports(module, tree):
    """``(line, imported module)`` for every import of a module of the package that runs (at import
    time or inside a function; not those under ``if TYPE_CHECKING:``).

    ``from x import y`` counts as an import of ``x.y`` when that is a module, else of ``x``.
    """
    out = []
    for node in _runtime_nodes(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if _inside(a.name)]
        elif isinstance(node, ast.ImportFrom):
            source = _resolve(module, node.level, node.module)
            if _inside(source):
                for a in node.names:
                    sub = f"{source}.{a.name}"
                    out.append((node.lineno, sub if sub in MODULES else source))
    return sorted(out)


def _private_crossings(module, tree):
    """``(line, name)`` for every private name this module takes from another module of the package."""
    out = []
    bound = {}  # local name -> module of the package it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if _inside(a.name):
                    if a.asname:
                        bound[a.asname] = a.name
                    else:
                        bound[a.name.split(".")[0]] = a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom):
            source = _resolve(module, node.level, node.module)
            if not _inside(source):
                continue
            for a in node.names:
                sub = f"{source}.{a.name}"
                if sub in MODULES:  # a module (a package-private module may keep its leading underscore)
                    bound[a.asname or a.name] = sub
                elif _private(a.name) and source != module:
                    out.append((node.lineno, f"{source}.{a.name}"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            chain, base = [], node.value
            while isinstance(base, ast.Attribute):
                chain.append(base.attr)
                base = base.value
            if isinstance(base, ast.Name) and base.id in bound:
                owner = ".".join([bound[base.id], *reversed(chain)])
                if owner in MODULES and owner != module and f"{owner}.{node.attr}" not in MODULES:
                    out.append((node.lineno, f"{owner}.{node.attr}"))
    return out


def _trees():
    for name, path in MODULES.items():
        yield name, path, ast.parse(path.read_text(), filename=str(path))


# Known crossings left for now, as (importing module, private name): each one is a debt, not a licence.
PRIVATE_ALLOWED: set = set()


def test_no_private_name_crosses_a_module_boundary():
    found, seen = [], set()
    for module, path, tree in _trees():
        for line, name in _private_crossings(module, tree):
            if (module, name) in PRIVATE_ALLOWED:
                seen.add((module, name))
            else:
                found.append(f"{path.relative_to(ROOT.parent)}:{line}: {name}")
    assert not found, ("private names taken from another module (make the name public in its module, or move "
                       "it to its only user):\n" + "\n".join(found))
    assert seen == PRIVATE_ALLOWED, f"no longer needed in PRIVATE_ALLOWED, remove: {sorted(PRIVATE_ALLOWED - seen)}"


def test_the_private_name_check_sees_each_form():
    """``from m import _x`` (also inside a function and relative), ``m._x`` after ``import`` or
    ``from package import m``; not dunders, not a module's own names, not private submodules."""
    src = """
from catadioptric.linefit.distances import _a
from .distances import _b, fine
import catadioptric.pose.central as central
from catadioptric.pose import rotation
from . import _common
from ._common import __doc__
def f():
    from ..pose.central import _c
    return central._d, rotation._e, _common._f, _common.ok
"""
    names = [name for _, name in _private_crossings("catadioptric.linefit.fits", ast.parse(src))]
    assert sorted(names) == sorted(["catadioptric.linefit.distances._a", "catadioptric.linefit.distances._b",
                                    "catadioptric.pose.central._c", "catadioptric.pose.central._d",
                                    "catadioptric.pose.rotation._e", "catadioptric.linefit._common._f"])


# --------------------------------------------------------------------------- layers
# The top-level modules and subpackages, low to high. A module may import its own unit and units of
# lower layers, never one of its own layer (units of a layer do not know each other) or a higher
# one: at import time or inside a function alike (imports under ``if TYPE_CHECKING:``, for
# annotations only, do not count). Imports by name (cli.py's table of subcommand modules, the
# package's lazy attributes) are not seen; cli.py sits at the top. The package itself
# (``catadioptric/__init__.py``, the facade, loaded before any submodule) is not a unit.
LAYERS = [
    ["_checks", "_io", "_numeric", "_pool"],
    ["_data", "_extras", "appearance", "curves", "frames", "mirrors", "observations", "solvers", "spectable", "viewlines"],
    ["projection", "render_presets"],  # projection: the solvers applied to a camera (duck-typed)
    ["lines", "vanishing"],
    ["cameras", "models"],  # the cameras' convenience methods call the layers below
    ["rigs", "unified"],
    ["centrality", "linefit", "rigspec"],
    ["formats", "scenes"],
    ["cliargs"],
    ["render"],
    ["dataset"],
    ["detect"],  # one image
    ["export", "photometric", "pose"],  # photometric: two images compared under a rotation
    ["look"],  # the pose's answers held against the images (photometric)
    ["twoview"],  # two images: detect, then pose
    ["validate"],
    ["jobs", "cli_centrality", "cli_chessboard"],
    ["cli"],
    ["demo"],
]

# Known upward imports, as (importing module, imported module): each is a debt to pay, not a licence.
UPWARD_ALLOWED = {
}


def _unit(module):
    """The unit of the layer list a module belongs to: its top-level module or subpackage."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def _layer_of():
    return {unit: k for k, layer in enumerate(LAYERS) for unit in layer}


def test_every_top_level_module_and_subpackage_has_a_layer():
    layer = _layer_of()
    missing = sorted({_unit(m) for m in MODULES} - set(layer) - {None})
    assert not missing, f"place these in LAYERS (tests/test_layout.py), above what they import: {missing}"
    twice = sorted(u for u in layer if sum(u in lay for lay in LAYERS) > 1)
    assert not twice, f"in more than one layer: {twice}"


def _upward(module, tree, layer):
    """``(line, imported module, why)`` for each import of ``module`` that does not point down."""
    out = []
    here = _unit(module)
    for line, target in _imports(module, tree):
        there = _unit(target)
        if there is None or there == here or here not in layer or there not in layer:
            continue
        if layer[there] >= layer[here]:
            why = "same layer" if layer[there] == layer[here] else "higher layer"
            out.append((line, target, why))
    return out


def test_imports_point_down_the_layers():
    layer = _layer_of()
    found = []
    for module, path, tree in _trees():
        for line, target, why in _upward(module, tree, layer):
            if (module, target) not in UPWARD_ALLOWED:
                found.append(f"{path.relative_to(ROOT.parent)}:{line}: imports {target} ({why})")
    assert not found, "imports that do not point down the layers (tests/test_layout.py, LAYERS):\n" + "\n".join(found)


def test_the_layer_check_sees_each_form():
    """Upward imports at import time, inside a function, relative, and ``from package import module``;
    not those under ``if TYPE_CHECKING:`` nor imports within the unit."""
    src = """
from typing import TYPE_CHECKING
import catadioptric.cameras
from .vanishing import vanishing_points
from . import lines
if TYPE_CHECKING:
    from .cameras import CatadioptricCamera
def f():
    from .solvers import reflection
    from .models.base import CentralCamera
    from .projection import Rays
"""
    found = [(t, why) for _, t, why in _upward("catadioptric.projection", ast.parse(src), _layer_of())]
    assert found == [("catadioptric.cameras", "higher layer"), ("catadioptric.vanishing", "higher layer"),
                     ("catadioptric.lines", "higher layer"), ("catadioptric.models.base", "higher layer")]


# --------------------------------------------------------------------------- parameter lists
MAX_PARAMETERS = 15  # inputs beyond this go into a dataclass of the data and one of the options


def _parameter_count(fn):
    """The parameters of a function (positional, keyword-only, ``*args``, ``**kwargs``), ``self`` or
    ``cls`` of a method not counted."""
    a = fn.args
    names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
    if names and names[0] in ("self", "cls"):
        names = names[1:]
    return len(names) + (a.vararg is not None) + (a.kwarg is not None)


def _long_parameter_lists(tree, limit=MAX_PARAMETERS):
    """``(line, name, count)`` of every function or method of ``tree`` taking more than ``limit``."""
    return [(node.lineno, node.name, _parameter_count(node)) for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _parameter_count(node) > limit]


def test_no_function_takes_more_than_15_parameters():
    found = [f"{path.relative_to(ROOT.parent)}:{line}: {name} takes {n}"
             for _, path, tree in _trees() for line, name, n in _long_parameter_lists(tree)]
    assert not found, (f"functions over {MAX_PARAMETERS} parameters (pass a dataclass of the inputs and one of the "
                       "options instead):\n" + "\n".join(found))


def test_the_parameter_check_counts_each_kind():
    """Positional-only, positional, keyword-only, ``*args`` and ``**kwargs`` count; ``self`` does not."""
    src = """
def ok(a, b, /, c, *args, d, **kw):
    pass
class C:
    def m(self, p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, p12, p13, p14):
        pass
    def wide(self, p0, p1, p2, p3, p4, p5, p6, p7, p8, p9, p10, p11, p12, p13, *, k, **kw):
        pass
"""
    tree = ast.parse(src)
    counts = {node.name: _parameter_count(node) for node in ast.walk(tree) if isinstance(node, ast.FunctionDef)}
    assert counts == {"ok": 6, "m": 15, "wide": 16}
    assert [(name, n) for _, name, n in _long_parameter_lists(tree)] == [("wide", 16)]

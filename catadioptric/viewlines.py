"""The lines one view sees, as the relative pose takes them (:class:`ViewLines`): what the line
detector produces (:meth:`catadioptric.detect.DetectedLines.to_view_lines`) and
:mod:`catadioptric.pose` reads; re-exported as :class:`catadioptric.pose.ViewLines`."""
from __future__ import annotations

from dataclasses import dataclass, field

from ._checks import CatadioptricError, as_float_array

__all__ = ["ViewLines"]


@dataclass
class ViewLines:
    """The lines one view sees: ``uv[i] (M_i, 2)`` pixels of line i, ``family[i]`` its family (any
    hashable key, the same key in both views for the same family), ``line_id[i]`` an id shared
    with the other view for the same 3-D line, or None (unknown correspondence). ``cam``: the
    view's camera (:class:`~catadioptric.cameras.CatadioptricCamera`, or a central
    :class:`~catadioptric.unified.UnifiedCamera`). ``appearance``: the colours either side of each
    line (:class:`~catadioptric.appearance.LineAppearance`, one row per line), or None (the lines'
    matching then goes by geometry alone)."""

    cam: object
    uv: list
    family: list
    line_id: list = field(default=None)
    appearance: object = field(default=None)

    def __post_init__(self):
        if not hasattr(self.cam, "backproject"):
            raise CatadioptricError(f"cam: expected a camera with backproject(), got {type(self.cam).__name__}")
        self.uv = [as_float_array(u, f"uv[{i}]", 2).reshape(-1, 2) for i, u in enumerate(self.uv)]
        self.family = list(self.family)
        if len(self.family) != len(self.uv):
            raise CatadioptricError(f"family: expected one family per line ({len(self.uv)}), got {len(self.family)}")
        if self.line_id is None:
            self.line_id = [None] * len(self.uv)
        self.line_id = list(self.line_id)
        if len(self.line_id) != len(self.uv):
            raise CatadioptricError(f"line_id: expected one id per line ({len(self.uv)}), got {len(self.line_id)}")
        if self.appearance is not None and len(self.appearance) != len(self.uv):
            raise CatadioptricError(f"appearance: expected one row per line ({len(self.uv)}), got "
                                    f"{len(self.appearance)}")

    def families(self) -> dict:
        """``{family: [line indices]}`` in the order of first appearance."""
        out: dict = {}
        for i, f in enumerate(self.family):
            out.setdefault(f, []).append(i)
        return out

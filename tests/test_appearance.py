"""The colours either side of a detected line (catadioptric.detect.appearance)."""
from __future__ import annotations

import numpy as np
import pytest

from catadioptric._checks import CatadioptricError
from catadioptric.detect.appearance import line_sides, side_distance

LEFT, RIGHT = np.array([200.0, 40.0, 10.0]), np.array([20.0, 90.0, 160.0])


def _image(w=100, h=80, edge=50):
    img = np.empty((h, w, 3))
    img[:, :edge] = LEFT
    img[:, edge:] = RIGHT
    return img


def test_a_step_edge_has_its_two_colours_one_each_side():
    # pixel centres are integers: the edge lies between columns 49 and 50
    uv = np.stack([np.full(40, 49.5), np.linspace(20, 60, 40)], axis=1)
    sides = line_sides(_image(), [uv], [0.0])
    assert sides.shape == (1, 2, 3)
    assert {tuple(np.round(s)) for s in sides[0]} == {tuple(LEFT), tuple(RIGHT)}


def test_a_band_is_skipped_by_its_width():
    img = _image()
    img[:, 45:55] = 255.0  # a light band 10 pixels wide over the edge
    uv = np.stack([np.full(30, 49.5), np.linspace(20, 50, 30)], axis=1)
    narrow = line_sides(img, [uv], [0.0])[0]
    wide = line_sides(img, [uv], [10.0])[0]
    assert np.allclose(narrow, 255.0)
    assert {tuple(np.round(s)) for s in wide} == {tuple(LEFT), tuple(RIGHT)}


def test_the_distance_ignores_the_order_of_the_sides():
    a = np.array([[LEFT, RIGHT]])
    assert side_distance(a, a[:, ::-1]) == pytest.approx([0.0])
    b = np.array([[LEFT + [3.0, 4.0, 0.0], RIGHT]])
    assert side_distance(a, b[:, ::-1]) == pytest.approx([2.5])  # (5 + 0) / 2


def test_a_side_off_the_image_is_nan():
    uv = np.stack([np.full(10, 0.5), np.linspace(10, 20, 10)], axis=1)
    sides = line_sides(_image(), [uv], [0.0], gap=5.0)
    assert np.isnan(sides[0]).any(axis=1).sum() == 1 and np.isfinite(sides[0]).all(axis=1).sum() == 1


def test_bad_input_is_named():
    uv = [np.zeros((5, 2))]
    with pytest.raises(CatadioptricError, match=r"width: expected one per line \(1\), got 2"):
        line_sides(_image(), uv, [0.0, 1.0])
    with pytest.raises(CatadioptricError, match=r"channels: expected an \(H, W\) or \(H, W, C\) array, got shape \(4,\)"):
        line_sides(np.zeros(4), uv, [0.0])
    with pytest.raises(CatadioptricError, match=r"a, b: expected sides of shape \(\.\.\., 2, C\) alike"):
        side_distance(np.zeros((1, 2, 3)), np.zeros((1, 3, 3)))

"""The image size limit (catadioptric.detect.image.MAX_PIXELS, docs/detect.md "Image size") on the
command line: ``relative-pose``, ``export --width/--height`` and ``detect`` refuse a larger image in
one line (exit 2) instead of running out of memory (20000x20000 gave a MemoryError traceback; issue
39, item 3). Small images throughout: the limit is lowered where an image must exceed it."""
from __future__ import annotations

import numpy as np

import catadioptric.detect.image as image_mod
from cli_errors import fails


def test_export_refuses_a_size_beyond_the_limit(capsys, tmp_path):
    msg = fails(["export", "--rig", "hyperboloid", "--format", "json", "--width", "20000", "--height", "20000"],
                 capsys)
    assert msg == ("catadioptric: error: --width/--height: expected at most 16.8 megapixels (16777216 pixels, e.g. "
                   "4096x4096: the memory limit of docs/detect.md, \"Image size\"), got 20000x20000")
    # one side given: the other is the rig's, and the product is checked
    msg = fails(["export", "--rig", "hyperboloid", "--format", "json", "--width", "200000"], capsys)
    assert "--width/--height: expected at most 16.8 megapixels" in msg and msg.endswith("got 200000x480")


def test_relative_pose_refuses_an_image_beyond_the_limit(capsys, tmp_path, monkeypatch):
    small = tmp_path / "small.npy"
    big = tmp_path / "big.npy"
    np.save(small, np.zeros((60, 80), np.uint8))
    np.save(big, np.zeros((90, 120), np.uint8))
    monkeypatch.setattr(image_mod, "MAX_PIXELS", 80 * 60)
    msg = fails(["relative-pose", str(small), str(big), "--rig", "hyperboloid", "--out", str(tmp_path / "o")],
                 capsys)
    assert msg.startswith("catadioptric: error: IMAGE_B: expected at most 0.0 megapixels (4800 pixels")
    assert msg.endswith("got 120x90")
    msg = fails(["relative-pose", str(big), str(small), "--rig", "hyperboloid", "--out", str(tmp_path / "o")],
                 capsys)
    assert "IMAGE_A: expected at most" in msg and msg.endswith("got 120x90")
    assert not (tmp_path / "o").exists()


def test_detect_refuses_an_image_beyond_the_limit(capsys, tmp_path, monkeypatch):
    big = tmp_path / "big.npy"
    np.save(big, np.zeros((90, 120), np.uint8))
    monkeypatch.setattr(image_mod, "MAX_PIXELS", 80 * 60)
    msg = fails(["detect", str(big), "--rig", "hyperboloid", "--out", str(tmp_path / "o")], capsys)
    assert msg.startswith("catadioptric: error: IMAGE: expected at most") and msg.endswith("got 120x90")

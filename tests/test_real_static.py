"""The static camera of ../shared/real/mei between the two images where the most moved (001 and
004: a person and the board moved, the camera did not): no mask, the truth is the identity and no
translation. Before ``pose.static`` the answer was a
half-turn (no prior) or 5.5 degrees off (prior 30), both flagged ambiguous; the issue's bound is
0.3 degree (docs/cameras.md, "How good it is")."""
from pathlib import Path

import cv2
import numpy as np
import pytest

from catadioptric.detect import detect_lines
from catadioptric.formats import load_camera
from catadioptric.pose import rotation_angle_deg
from catadioptric.twoview import pose_from_detections

MEI = Path(__file__).resolve().parents[2] / "shared" / "real" / "mei"

pytestmark = pytest.mark.skipif(not MEI.is_dir(), reason=f"the real images of {MEI} are not on this machine")


@pytest.fixture(scope="module")
def detections():
    cam = load_camera(str(MEI / "mei_omnidir.yaml"))
    return [detect_lines(cv2.imread(str(MEI / n), cv2.IMREAD_GRAYSCALE), cam) for n in ("img_para_001.png", "img_para_004.png")]


def test_a_board_and_a_person_that_moved_do_not_move_the_camera(detections):
    # without a prior, the harder case (the half-turns are candidates too); the prior of a tripod
    # (validate.real.STATIC_PRIOR_DEG) is in the committed report, 0.051 deg (one run costs 15-20 s)
    p = pose_from_detections(*detections).pose
    assert not p.ambiguous, p.notes
    assert rotation_angle_deg(p.R) < 0.3
    assert any(n.startswith("decisive as a camera turned in place") for n in p.notes), p.notes
    assert not p.translation_observable and np.array_equal(p.t, np.zeros(3))

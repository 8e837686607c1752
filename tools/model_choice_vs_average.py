"""Choosing the model pair by pair against averaging the two rotations, on the benchmark's stored
draws (docs/relative_pose.md, "Choosing the model pair by pair").

    .venv/bin/python tools/model_choice_vs_average.py [RESULTS]

``RESULTS``: the label results of ``catadioptric validate benchmark`` (default
``render/out/relative_pose_benchmark/results``). Per configuration and noise level, the median
rotation error of the exact model, of the central baseline, of ``selected`` (``pose.choose_model``,
as stored with each draw) and of ``averaged``: the two rotations averaged by their inverse
variances (``rotation_std_deg``) along the geodesic between them, as if the two answers were
independent (they share every pixel). Draws where either answer is ambiguous or failed are left out;
results from code older than ``pose.choose_model`` (no ``selected``) stop it with their count.
"""
from __future__ import annotations

import collections
import json
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from catadioptric.pose import rotation_angle_deg


def main() -> None:
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else "render/out/relative_pose_benchmark/results")
    cells = collections.defaultdict(list)
    paths = sorted(folder.glob("*/p*.json"))
    if not paths:
        sys.exit(f"{folder}: no per-pair results (*/p*.json); run the benchmark first (README)")
    older = 0
    for path in paths:
        r = json.loads(path.read_text())
        R_gt = np.array(r["R_gt"])
        for d in r["draws"]:
            c = d.get("central", {})
            if "error" in d or "error" in c or not c or d["ambiguous"] or c["ambiguous"]:
                continue
            if "selected" not in d:
                older += 1
                continue
            Re, Rc = np.array(d["R"]), np.array(c["R"])
            we, wc = d["rotation_std_deg"] ** -2, c["rotation_std_deg"] ** -2
            step = Rotation.from_matrix(Rc @ Re.T).as_rotvec() * wc / (we + wc)
            Ra = Rotation.from_rotvec(step).as_matrix() @ Re
            cells[(r["config"], d["noise_px"])].append(
                [d["rotation_error_deg"], c["rotation_error_deg"], d["selected"]["rotation_error_deg"],
                 rotation_angle_deg(Ra @ R_gt.T)])
    if older:
        sys.exit(f"{folder}: {older} draws carry no 'selected' (results of code older than pose.choose_model); "
                 "run the benchmark again")
    print("configuration | noise (px) | draws | exact | central | selected | averaged")
    for (config, noise), v in sorted(cells.items()):
        m = np.median(np.array(v), axis=0)
        print(f"{config} | {noise:g} | {len(v)} | " + " | ".join(f"{x:.3f}" for x in m))


if __name__ == "__main__":
    main()

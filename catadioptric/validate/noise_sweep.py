"""Noise sweeps on synthetic data for the paper's four configurations (its Figs. 5 and 6).

For each rig preset and noise level, over ``trials`` seeded random trials:

* vanishing points from noisy directions: the direction turned by a random angle of the
  noise level (degrees); error = distance between the true and the noisy direction's
  observable vanishing points on the mirror (mm) and in the image (px);
* directions from noisy vanishing points: Gaussian pixel noise on the true vanishing point;
  error = angle between the true direction and ``cam.directions_from_vanishing_points``;
* absolute rotation: three random world directions rotated by a random ground-truth rotation,
  their vanishing points with pixel noise, directions back, orthogonal Procrustes; error =
  ``|R_gt - R|_F`` (the paper's measure) and the angle in degrees.
"""
from __future__ import annotations

import numpy as np

from ..pose import rotation_angle_deg, rotation_from_directions
from ..rigs import preset
from .report import md_table

RIGS = ["sphere", "ellipsoid", "hyperboloid", "hyperboloid_central"]
DIRECTION_NOISE_DEG = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
PIXEL_NOISE = [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _observable(cam, n, rng):
    """n random unit directions with an observable vanishing point on the image."""
    out = []
    while sum(len(o) for o in out) < n:
        s = _unit(rng.normal(size=(4 * n, 3)))
        vp = cam.vanishing_points(s)
        out.append(s[vp.valid[:, 0] & vp.in_image[:, 0]])
    return np.concatenate(out)[:n]


def _perturb(s, deg, rng):
    """Turn each direction by ``deg`` degrees about a random perpendicular axis."""
    a = _unit(np.cross(s, rng.normal(size=s.shape)))
    t = np.radians(deg)
    return np.cos(t) * s + np.sin(t) * np.cross(a, s)


def _rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def run(rigs=RIGS, trials: int = 100, seed: int = 0) -> dict:
    res = {"trials": trials, "seed": seed, "direction_noise_deg": DIRECTION_NOISE_DEG, "pixel_noise": PIXEL_NOISE,
           "rigs": {}}
    for name in rigs:
        cam = preset(name)
        rng = np.random.default_rng(seed)
        s = _observable(cam, trials, rng)
        vp0 = cam.vanishing_points(s)
        r0, uv0 = vp0.mirror_points[:, 0], vp0.uv[:, 0]
        vp_mm, vp_px, dir_deg, rot_f, rot_deg = [], [], [], [], []
        for deg in DIRECTION_NOISE_DEG:
            vp = cam.vanishing_points(_perturb(s, deg, rng))
            ok = vp.valid[:, 0]
            vp_mm.append(float(np.median(np.linalg.norm(vp.mirror_points[ok, 0] - r0[ok], axis=1)) * 1e3))
            vp_px.append(float(np.median(np.linalg.norm(vp.uv[ok, 0] - uv0[ok], axis=1))))
        for px in PIXEL_NOISE:
            d = cam.directions_from_vanishing_points(uv0 + rng.normal(scale=px, size=uv0.shape))
            ok = np.all(np.isfinite(d), axis=1)
            dir_deg.append(float(np.median(np.degrees(np.arccos(np.clip(np.sum(d[ok] * s[ok], 1), -1, 1))))))
            fs, ds = [], []
            for _ in range(trials):
                Rg = _rotation(rng)
                w = _unit(rng.normal(size=(3, 3)))
                sm = w @ Rg.T
                vp = cam.vanishing_points(sm)
                if not np.all(vp.valid[:, 0]):
                    continue
                dm = cam.directions_from_vanishing_points(vp.uv[:, 0] + rng.normal(scale=px, size=(3, 2)))
                if not np.all(np.isfinite(dm)):
                    continue
                R = rotation_from_directions(w, dm)
                fs.append(np.linalg.norm(R - Rg))
                ds.append(rotation_angle_deg(R @ Rg.T))
            rot_f.append(float(np.median(fs)) if fs else np.nan)
            rot_deg.append(float(np.median(ds)) if ds else np.nan)
        res["rigs"][name] = {"camera": cam.to_dict(), "solver": cam.solver.name, "central": cam.is_central,
                             "vp_error_mm": vp_mm, "vp_error_px": vp_px, "direction_error_deg": dir_deg,
                             "rotation_error_frobenius": rot_f, "rotation_error_deg": rot_deg}
    return res


def markdown(res: dict, command: str) -> str:
    out = ["# Noise sweeps (the paper's Figs. 5 and 6, synthetic)", "",
           f"Median over {res['trials']} seeded trials (seed {res['seed']}) per level; rigs from `catadioptric.rigs`.",
           ""]
    dn, pn = res["direction_noise_deg"], res["pixel_noise"]
    for title, key, levels, unit in [
            ("Vanishing point error on the mirror (mm) vs direction noise (deg)", "vp_error_mm", dn, "deg"),
            ("Vanishing point error in the image (px) vs direction noise (deg)", "vp_error_px", dn, "deg"),
            ("Direction error (deg) vs vanishing point noise (px)", "direction_error_deg", pn, "px"),
            ("Absolute rotation error |R_gt - R|_F vs vanishing point noise (px)", "rotation_error_frobenius", pn, "px"),
            ("Absolute rotation error (deg) vs vanishing point noise (px)", "rotation_error_deg", pn, "px")]:
        out += [f"## {title}", "", md_table(["rig"] + [f"{v:g} {unit}" for v in levels],
                                            [[n] + r[key] for n, r in res["rigs"].items()]), ""]
    out += [f"Reproduce: `{command}`", ""]
    return "\n".join(out)


def figure(res: dict):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13.5, 3.8), dpi=100)
    for name, r in res["rigs"].items():
        axes[0].plot(res["direction_noise_deg"], r["vp_error_mm"], "o-", label=name)
        axes[1].plot(res["pixel_noise"], r["direction_error_deg"], "o-", label=name)
        axes[2].plot(res["pixel_noise"], r["rotation_error_frobenius"], "o-", label=name)
    axes[0].set(xlabel="direction noise (deg)", ylabel="VP error on the mirror (mm)", title="VPs from directions")
    axes[1].set(xlabel="VP noise (px)", ylabel="direction error (deg)", title="directions from VPs")
    axes[2].set(xlabel="VP noise (px)", ylabel="|R_gt - R|_F", title="absolute rotation (3 VPs)")
    for a in axes:
        a.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    return fig

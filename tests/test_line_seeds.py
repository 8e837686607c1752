"""The starting samples of line images: the grid's angular resolution and the seeds of each line
(the pairs the plane bound skips never pass the test)."""
import numpy as np
import pytest

from catadioptric._numeric import norm, unit
from catadioptric.curves import pixel_grid_rays
from catadioptric.lines import _line_seeds
from catadioptric.rigs import preset


@pytest.mark.parametrize("name", ["hyperboloid_9pct", "sphere"])
def test_grid_angles_are_the_angles_between_neighbouring_rays(name):
    cam = preset(name, width=320, height=240)
    o, d, ang = pixel_grid_rays(cam, 4)
    rays = cam.backproject(cam.pinhole.pixel_grid(4))
    D = rays.directions
    right = np.arccos(np.clip(np.sum(D[:, 1:] * D[:, :-1], axis=-1), -1, 1))
    down = np.arccos(np.clip(np.sum(D[1:] * D[:-1], axis=-1), -1, 1))
    want = np.full(D.shape[:2], np.nan)
    want[:, :-1] = right
    want[:-1] = np.fmax(want[:-1], down)
    ok = rays.valid & np.isfinite(want)
    assert np.allclose(ang, want[ok], rtol=1e-12, atol=0)
    assert 0 < np.median(ang) < 0.1  # a few pixels' worth of angle, not a right angle


def _brute_seeds(cam, q, s, step, max_per_line=256):
    """Every (line, ray) pair tested, one line at a time."""
    o, d, ang = pixel_grid_rays(cam, step)
    ids, lams = [], []
    for i in range(len(q)):
        w0 = o - q[i]
        b = np.einsum("nk,nk->n", d, np.broadcast_to(s[i], d.shape))
        sw = np.einsum("nk,nk->n", w0, np.broadcast_to(s[i], d.shape))
        e = np.sum(d * w0, axis=1)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t = (b * sw - e) / (1.0 - b * b)
            lam = sw + t * b
            gap = norm(o + t[:, None] * d - (q[i] + lam[:, None] * s[i]))
            hit = (t > 0) & (gap <= 1.5 * ang * t)
        lam = np.sort(lam[hit])
        if len(lam) > max_per_line:
            lam = lam[np.linspace(0, len(lam) - 1, max_per_line).astype(int)]
        ids.append(np.full(len(lam), i))
        lams.append(lam)
    return np.concatenate(ids), np.arctan(np.concatenate(lams) / cam.mirror.scale)


@pytest.mark.parametrize("name", ["hyperboloid_9pct", "sphere", "cone"])
def test_seeds_equal_testing_every_pair(name):
    cam = preset(name, width=320, height=240)
    rng = np.random.default_rng(4)
    ell = cam.mirror.scale
    # lines from near the mirror (every ray kept) to far away (most rays skipped)
    q = rng.normal(size=(60, 3)) * ell * rng.uniform(0.5, 200.0, (60, 1))
    s = unit(rng.normal(size=(60, 3)))
    ids, par = _line_seeds(cam, q, s, 4)
    want_ids, want_par = _brute_seeds(cam, q, s, 4)
    assert len(want_ids) > 1000
    a, b = np.lexsort((par, ids)), np.lexsort((want_par, want_ids))
    assert np.array_equal(ids[a], want_ids[b]) and np.array_equal(par[a], want_par[b])

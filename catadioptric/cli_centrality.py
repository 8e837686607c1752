"""The ``catadioptric centrality`` command: how far a rig is from central, as the report of
:mod:`catadioptric.centrality` (which holds the measurement; this module only its command line)."""
from __future__ import annotations

__all__ = ["register"]


def _run(args) -> int:
    from ._extras import require
    from .centrality import PAPER_DEG, centrality_report
    from .cliargs import check_out_dir, resolve_rig

    cam, _ = resolve_rig(args.rig, width=args.width, height=args.height)
    check_out_dir(args.out)
    require("matplotlib", "catadioptric centrality (its heat map)")  # before the work, not after the JSON
    rep = centrality_report(cam, rig=args.rig, n_directions=args.n_directions, seed=args.seed, step=args.step,
                            fit_step=args.fit_step, vp_method=args.vp_method)
    paths = rep.save(args.out)
    S = rep.summary()
    off = "" if S["offset_m"] is None else f", camera {S['offset_m'] * 1e3:.3g} mm ({S['offset_pct']:.3g} %) off the focus"
    print(f"rig {args.rig}: {cam.mirror.kind}{off}, central={S['is_central']}")
    for k, label in (("central", "central approximation (unified + tilt)"), ("omnidir", "omnidir (pure Mei model)")):
        a = S[k]
        print(f"  {label}:")
        print(f"    per-pixel angular error: max {a['pixel_max_deg']:.4g} deg, median {a['pixel_median_deg']:.4g} deg")
        if a["vp_max_px"] is not None:
            print(f"    vanishing points ({S['n_vp_seen']} of {S['n_directions']} directions seen): "
                  f"max {a['vp_max_px']:.4g} px / {a['vp_max_deg']:.4g} deg, "
                  f"median {a['vp_median_px']:.4g} px / {a['vp_median_deg']:.4g} deg")
        print(f"    fit reprojection rms {a['fit_rms_px']:.4g} px")
    print(f"  paper (Sec. 5.5, rig about 9 % off central): {PAPER_DEG:g} deg")
    print(f"  exact vanishing points: {rep.vp_method}; {rep.seconds:.1f} s")
    for p in paths.values():
        print(f"wrote {p}")
    return 0


def register(sub) -> None:
    from .cliargs import RIG_HELP, nonnegative_int, positive_int

    p = sub.add_parser("centrality", help="how far a rig is from central: error of its best unified-model fit")
    p.add_argument("--rig", default="hyperboloid_9pct", help=RIG_HELP + " (default: hyperboloid_9pct)")
    p.add_argument("--out", default="out/centrality",
                   help="output folder (default: out/centrality; the committed report is validate/centrality)")
    p.add_argument("--width", type=positive_int, help="image width in pixels (default: the rig's, 640)")
    p.add_argument("--height", type=positive_int, help="image height in pixels (default: the rig's, 480)")
    p.add_argument("--step", type=positive_int, default=1, help="pixel stride of the error map (default 1: every pixel)")
    p.add_argument("--fit-step", type=positive_int, default=4, help="pixel stride of the fit samples (default 4)")
    p.add_argument("--n-directions", type=nonnegative_int, default=200,
                   help="seeded random directions (default 200)")
    p.add_argument("--seed", type=nonnegative_int, default=0, help="seed of the random directions (default 0)")
    p.add_argument("--vp-method", default="auto", choices=["auto", "solver", "extrapolation"],
                   help="exact vanishing points: the solver (catadioptric.vanishing) or extrapolation")
    p.set_defaults(func=_run)

"""``catadioptric validate``: run an experiment and write its report (JSON + Markdown + PNG)."""
from __future__ import annotations

import shlex
import sys


def _relative_rotation(args) -> int:
    from . import relative_rotation as rr
    from .report import write_report

    res = rr.run_seeds(args.dataset, range(args.seed, args.seed + args.draws), noise_px=args.noise,
                       max_pixels=args.max_pixels, central=not args.no_central)
    cmd = "catadioptric " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if args.command_line is None \
        else args.command_line
    paths = write_report(args.out, res, rr.markdown(res, cmd), {"vanishing_points": rr.figure(res, args.dataset)})
    print_summary(res)
    print("wrote " + ", ".join(paths))
    return 0


def print_summary(res: dict) -> None:
    A, B = res["views"]
    used = [r for r in res["families"] if r["used"]]
    print(f"relative rotation {A} -> {B} from {len(used)} families of parallel lines "
          f"(noise {res['noise_px']} px):")
    print(f"  non-central (exact) model : {res['angle_error_deg']:.4f} deg, Frobenius {res['frobenius_error']:.4f}")
    if "central" in res:
        c = res["central"]
        print(f"  central approximation     : {c['angle_error_deg']:.4f} deg, Frobenius {c['frobenius_error']:.4f}")
    if len(res.get("draws", {}).get("rows", [])) > 1:
        d = res["draws"]
        print(f"  over {len(d['rows'])} noise draws: median {d['median_deg']:.4f} deg, max {d['max_deg']:.4f} deg "
              f"(central: median {d['central_median_deg']:.4f}, max {d['central_max_deg']:.4f})")
    print("  (the paper, CVPR 2018 Sec. 5.4: Frobenius 0.0446 on its POV-Ray pair)")


def _noise_sweep(args) -> int:
    from . import noise_sweep as ns
    from .report import write_report

    res = ns.run(trials=args.trials, seed=args.seed)
    cmd = f"catadioptric validate noise-sweep --out {args.out} --trials {args.trials} --seed {args.seed}"
    paths = write_report(args.out, res, ns.markdown(res, cmd), {"noise_sweep": ns.figure(res)})
    for name, r in res["rigs"].items():
        print(f"  {name:22s} direction error at 10 px: {r['direction_error_deg'][-1]:.3f} deg; rotation |dR|_F at "
              f"10 px: {r['rotation_error_frobenius'][-1]:.4f}")
    print("wrote " + ", ".join(paths))
    return 0


def register(sub) -> None:
    p = sub.add_parser("validate", help="experiments on rendered datasets (relative rotation, ...)")
    vs = p.add_subparsers(dest="experiment", required=True)
    r = vs.add_parser("relative-rotation", help="relative rotation of a two-view dataset from vanishing points")
    r.add_argument("dataset", metavar="DATASET", help="dataset folder written by `catadioptric render`")
    r.add_argument("--out", required=True, metavar="DIR", help="report folder")
    r.add_argument("--noise", type=float, default=2.0, help="Gaussian pixel noise added to line pixels (default 2)")
    r.add_argument("--seed", type=int, default=0, help="first noise seed (default 0)")
    r.add_argument("--draws", type=int, default=1, help="noise draws (seeds seed, seed+1, ...; default 1)")
    r.add_argument("--max-pixels", type=int, default=150, help="pixels per line at most (default 150)")
    r.add_argument("--no-central", action="store_true", help="skip the central (unified) approximation")
    r.set_defaults(func=_relative_rotation, command_line=None)
    n = vs.add_parser("noise-sweep", help="synthetic noise sweeps of VPs, directions and rotation (paper Figs. 5-6)")
    n.add_argument("--out", required=True, metavar="DIR", help="report folder")
    n.add_argument("--trials", type=int, default=100, help="trials per noise level (default 100)")
    n.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    n.set_defaults(func=_noise_sweep)

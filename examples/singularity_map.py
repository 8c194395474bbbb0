"""Singularity maps of the caster robots (docs/physics/three-wheel.md TW-2, caster-singularity
paper).

Plots ``det J_S`` of the ThreeWheel robot over two steering angles for three input-joint
choices (the three-wheel paper's ``(drive_1, drive_2, steer_3)``, all drives, all steering
joints), the zero level (the singular configurations) in black, and ``det J_S`` of the
CasterAGV over its swivel angle for every pair of joints. Also prints the singular
configurations the grid scan finds.

    python examples/singularity_map.py --out singularity_map.png
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

from wheelgym.kinematics import SingularityAnalysis
from wheelgym.models import CasterAGV, ThreeWheel

TW_SETS = (
    ("drive_1", "drive_2", "steer_3"),
    ("drive_1", "drive_2", "drive_3"),
    ("steer_1", "steer_2", "steer_3"),
)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="singularity_map.png", help="PNG file to write")
    parser.add_argument("--n", type=int, default=181, help="grid points per axis")
    parser.add_argument("--psi3", type=float, default=0.0,
                        help="steering angle of wheel 3 held fixed in the maps (rad)")
    args = parser.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tw = ThreeWheel()
    agv = CasterAGV()
    fig, axes = plt.subplots(1, 4, figsize=(19, 4.6))
    for ax, joints in zip(axes[:3], TW_SETS, strict=True):
        a = SingularityAnalysis(tw, joints)
        g1, g2, det = a.det_grid(axes=(0, 1), n=args.n, fixed=[0.0, 0.0, args.psi3])
        lim = float(np.max(np.abs(det)))
        im = ax.pcolormesh(g1, g2, det.T, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="auto")
        ax.contour(g1, g2, det.T, levels=[0.0], colors="k", linewidths=1.5)
        ax.set_title(f"ThreeWheel det J_S, S = {', '.join(joints)}", fontsize=9)
        ax.set_xlabel("psi_1 (rad)")
        ax.set_ylabel("psi_2 (rad)")
        fig.colorbar(im, ax=ax, shrink=0.85)
        scan = a.scan(n=36)
        print(f"ThreeWheel S = {joints}: {len(scan)} singular configurations on a 36^3 grid "
              f"(min s_min/s_max {scan.min_ratio:.2g})")
    sig = np.linspace(-np.pi, np.pi, 721)
    ax = axes[3]
    for joints in itertools.combinations(agv.joint_names, 2):
        a = SingularityAnalysis(agv, joints)
        d = a.det(sig)
        ax.plot(sig, d / np.max(np.abs(d)), label=", ".join(joints))
        roots = a.scan().configs[:, 0]
        print(f"CasterAGV S = {joints}: singular at sigma = {np.round(roots, 6).tolist()}")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_title("CasterAGV det J_S (normalised)", fontsize=9)
    ax.set_xlabel("sigma (rad)")
    ax.legend(fontsize=7)
    fig.suptitle(f"Singularity maps (psi_3 = {args.psi3:g} rad; black: det J_S = 0)")
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()

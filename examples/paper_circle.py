"""The three-wheel paper's simulation (section 5, docs/physics/three-wheel.md TW-7), with its Fig. 4
and Fig. 5.

Inverse dynamics along the paper's trajectory (beta(t) quintic, 0 -> 2 pi in 60 s, the
platform's x axis tangent to a 1 m circle) gives the generalized force and, through the
minimum-norm load distribution of the paper's eq. (36), the six motor torques. Forward
dynamics (RK4) with those torques, open loop, then reproduces the joint angles of the
inverse-kinematics integration: the paper reports 1e-2 to 1e-3 rad of error, wheelgym about
1e-11 rad at the default 2 ms step. The torques are recomputed at every RK4 stage time from the
reference (see :mod:`wheelgym.control.experiment`), so the scheme stays fourth order.

Usage::

    python examples/paper_circle.py --out figures/        # PNGs: fig4_paper_circle.png, fig5_...
    python examples/paper_circle.py --low-res --dt 0.02   # quick look
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from wheelgym.control import paper_distribution
from wheelgym.control.experiment import paper_experiment
from wheelgym.models import ThreeWheel


def joint_accelerations(model: ThreeWheel, res: dict) -> np.ndarray:
    """``qddot = J udot + Jdot u`` (TW-1 differentiated: dg/dpsi = h, dh/dpsi = -g)."""
    p = model.params
    J, u, ud = res["J"], res["twist"], res["twist_rate"]
    qd = np.einsum("nij,nj->ni", J, u)
    psid = qd[:, 3:]
    g = J[:, :3, :] * p.r  # g_i
    h = (J[:, 3:, :] + np.array([0.0, 0.0, 1.0])) * p.d  # h_i
    Jdot = np.concatenate([psid[..., None] * h / p.r, -psid[..., None] * g / p.d], axis=1)
    return np.einsum("nij,nj->ni", J, ud) + np.einsum("nij,nj->ni", Jdot, u)


def make_figures(res: dict, model: ThreeWheel, out: Path, dpi: int) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = res["t"]
    J = res["J"]
    qd = np.einsum("nij,nj->ni", J, res["twist"])
    qdd = joint_accelerations(model, res)
    tau_dist, q_s = paper_distribution(J, res["Q"])  # paper (30) torques and (36) distribution
    theta = res["theta_ref"]

    fig, ax = plt.subplots(4, 2, figsize=(11, 13))
    ax = ax.ravel()
    ax[0].plot(t, theta[:, 0], "-", t, theta[:, 1], ":", t, theta[:, 2], "--")
    ax[0].set(title="(a) wheel angles", ylabel="rad")
    ax[0].legend([r"$\theta_1$", r"$\theta_2$", r"$\theta_3$"])
    ax[1].plot(t, qd[:, 0], "-", t, qd[:, 1], ":", t, qd[:, 2], "--")
    ax[1].set(title="(b) wheel rates", ylabel="rad/s")
    ax[1].legend([r"$\dot\theta_1$", r"$\dot\theta_2$", r"$\dot\theta_3$"])
    ax[2].plot(t, qdd[:, 0], "-", t, qdd[:, 1], ":")
    ax[2].set(title="(c) wheel accelerations", ylabel="rad/s²")
    ax[2].legend([r"$\ddot\theta_1$", r"$\ddot\theta_2$"])
    ax[3].plot(t, res["twist"][:, 2])
    ax[3].set(title="(d) body rotation rate", ylabel="rad/s")
    ax[4].plot(t, q_s[:, 0], "-", t, q_s[:, 1], ":", t, q_s[:, 2], "--")
    ax[4].set(title="(e) independent-joint torques (paper (30))", ylabel="N·m")
    ax[4].legend([r"$\tau_1$ drive 1", r"$\tau_2$ drive 2", r"$\tau_3$ steer 3"])
    ax[5].plot(t, tau_dist[:, 0], "-", t, tau_dist[:, 1], ":", t, tau_dist[:, 5], "--")
    ax[5].set(title="(f) distributed torques, independent joints", ylabel="N·m")
    ax[5].legend(["drive 1", "drive 2", "steer 3"])
    ax[6].plot(t, tau_dist[:, 3], "-", t, tau_dist[:, 4], ":", t, tau_dist[:, 2], "--")
    ax[6].set(title="(g) distributed torques, dependent joints", ylabel="N·m")
    ax[6].legend(["steer 1 (A1)", "steer 2 (A2)", "drive 3 (O3)"])
    pose = res["pose"]
    x = res["x"]
    ax[7].plot(pose[:, 0], pose[:, 1], "-", x[:, 0], x[:, 1], ":")
    ax[7].set(title="path (reference, simulated)", xlabel="x (m)", ylabel="y (m)", aspect="equal")
    for a in ax[:7]:
        a.set_xlabel("t (s)")
        a.grid(alpha=0.3)
    fig.suptitle("Three-wheel paper Fig. 4: inverse dynamics on the quintic circle")
    fig.tight_layout()
    f4 = out / "fig4_paper_circle.png"
    fig.savefig(f4, dpi=dpi)
    plt.close(fig)

    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    err = res["theta_error"]
    ax[0].plot(t, err[:, 0], "-", t, err[:, 1], ":")
    ax[0].set(title="(a) angle error at O1, O2 (forward dynamics - inverse kinematics)",
              xlabel="t (s)", ylabel="rad")
    ax[0].legend([r"$\theta_1$", r"$\theta_2$"])
    ax[1].plot(t, res["psi_error"])
    ax[1].set(title="(b) steering-angle error", xlabel="t (s)", ylabel="rad")
    ax[1].legend([r"$\psi_1$", r"$\psi_2$", r"$\psi_3$"])
    for a in ax:
        a.grid(alpha=0.3)
    fig.suptitle("Three-wheel paper Fig. 5: joint-angle error of the open-loop simulation")
    fig.tight_layout()
    f5 = out / "fig5_paper_circle_error.png"
    fig.savefig(f5, dpi=dpi)
    plt.close(fig)
    return [f4, f5]


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("paper_circle_figures"),
                        help="directory for the PNG figures")
    parser.add_argument("--dt", type=float, default=ThreeWheel.default_sim_dt,
                        help="RK4 step (s), default the model's sim_dt")
    parser.add_argument("--low-res", action="store_true", help="small, low-dpi figures")
    args = parser.parse_args(argv)
    model = ThreeWheel()
    res = paper_experiment(model, dt=args.dt)
    args.out.mkdir(parents=True, exist_ok=True)
    step = max(1, len(res["t"]) // 400) if args.low_res else 1
    sub = {k: v[::step] for k, v in res.items()}
    files = make_figures(sub, model, args.out, dpi=50 if args.low_res else 120)
    e_theta = float(np.abs(res["theta_error"]).max())
    e_psi = float(np.abs(res["psi_error"]).max())
    print(f"step {args.dt} s, {len(res['t']) - 1} RK4 steps over {res['t'][-1]:.0f} s")
    print(f"max |theta error| = {e_theta:.3e} rad   (paper: 1e-2 .. 1e-3 rad)")
    print(f"max |psi error|   = {e_psi:.3e} rad")
    print(f"max |tau| per motor (N·m): {np.round(np.abs(res['tau']).max(axis=0), 4)}")
    for f in files:
        print(f"wrote {f}")
    return {"theta_error": e_theta, "psi_error": e_psi, "files": files}


if __name__ == "__main__":
    main()

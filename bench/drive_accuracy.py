"""Accuracy of the online ICR EKF on the real Warthog logs (../shared/data/drive).

Prints every figure of docs/results/real_logs.md:

1. model-odometry error (Baril et al.: translational m/m and angular deg/m over
   h_e = 2 m windows, median and quartiles) pooled over the five grass runs, for
   the ideal differential drive, constant models fitted offline (on the grass
   runs themselves - an optimistic oracle - and on the asphalt run), and the
   online EKF in several configurations (with / without the slip state alpha,
   calibrated / nominal start);
2. re-convergence of the ICR estimates after the grass -> asphalt switch of
   the stitched log, with and without the P_B reset.

Constant models are fitted with the offline identification of ``terrain-odom fit``
(terrain_odom.app.fit.fit: differential evolution + least-squares polish of
Baril eq. 13 with Sigma = I on distinct 2 m segments).

Usage::

    python bench/drive_accuracy.py [--data ../shared/data/drive] [--config config/warthog.yaml]

Takes a few minutes on one core.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from terrain_odom.app.fit import fit
from terrain_odom.config import IcrState, load_config
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.evaluation import (
    icr_twist_from_rows,
    model_twist,
    settling_time,
    spatial_windows,
    window_errors,
)
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import get_model

REPO = Path(__file__).resolve().parents[1]


def pooled(errors):
    """Median [q25-q75] of pooled per-window errors: (m/m, deg/m)."""
    trans = np.concatenate([e.translation_per_m for e in errors])
    rot = np.concatenate([e.rotation_per_m for e in errors])
    return np.percentile(trans, [50, 25, 75]), np.percentile(rot, [50, 25, 75]), trans.size


def line(name, errors):
    (tm, t1, t3), (rm, r1, r3), n = pooled(errors)
    print(f"  {name:<52} {tm:.4f} [{t1:.3f}-{t3:.3f}]  {rm:.3f} [{r1:.2f}-{r3:.2f}]  (n={n})")
    return tm, rm


def fit_constant(model_name, logs, cfg):
    """Parameters of a constant model fitted on the logs (``terrain-odom fit``)."""
    return fit(logs, model_name, config=cfg).params.vector()


def ekf_errors(logs, windows, cfg):
    errs = []
    for log, win in zip(logs, windows, strict=True):
        res = run_icr_ekf(log, cfg, labels=log.terrain)
        cols = {n: res.states[:, i] for i, n in enumerate(res.names)}
        icr = (cols["y_l"], cols["y_r"], cols["x_icr"], cols.get("alpha", np.ones(len(log))))
        errs.append(window_errors(log, win, icr_twist_from_rows(win, *icr)))
    return errs


def with_ekf(cfg, **changes):
    return dataclasses.replace(cfg, ekf=dataclasses.replace(cfg.ekf, **changes))


def reconvergence(cfg, data, title):
    """Settling of the ICRs after the terrain switch of the stitched log."""
    log = read_wheel_log(
        data / "stitched_grass_to_asphalt.csv", wheel_radius=cfg.robot.wheel_radius
    )
    switch = float(log.t[np.flatnonzero(log.terrain != log.terrain[0])[0]])
    moving = (np.abs(log.v_l) + np.abs(log.v_r) > 0.05) & (log.t >= switch)
    t_move = float(log.t[np.flatnonzero(moving)[0]])
    with_reset = run_icr_ekf(log, cfg, labels=log.terrain).states[:, 3:]
    without = run_icr_ekf(log, cfg, labels=None).states[:, 3:]
    final = with_reset[-1]
    half = 0.5 * (final[0] - final[1])
    # 10 % of each final value; x_icr (near zero) against 10 % of the half spacing
    tol = 0.1 * np.abs(final)
    tol[2] = 0.1 * half
    print(
        f"\n{title}: re-convergence after the grass -> asphalt switch (t = {switch:.1f} s; the robot"
    )
    print(f"stands still until t = {t_move:.1f} s, so times are counted from the first motion)")
    print(
        f"  final asphalt estimate (with reset): y_l={final[0]:.3f} y_r={final[1]:.3f} "
        f"x_icr={final[2]:.3f} alpha={final[3] if final.size > 3 else 1.0:.3f}"
    )
    print(f"  final estimate without reset:        {np.array2string(without[-1], precision=3)}")
    # control-engineering settling: parameters that change by > 5 % of their scale
    # (their value; the half spacing for x_icr), within 10 % of their step
    before = with_reset[np.searchsorted(log.t, switch) - 1]
    step = np.abs(final - before)
    scale = np.abs(final)
    scale[2] = half
    moved = step > 0.05 * scale
    names = np.array(["y_l", "y_r", "x_icr", "alpha"][: final.size])
    print(
        f"  parameters that change by > 5 %: {', '.join(names[moved])} "
        f"(step {np.array2string(step[moved], precision=3)})"
    )
    for name, states in (("with P_B reset", with_reset), ("without reset", without)):
        s10 = settling_time(log.t, states, final, tol, t_from=t_move)
        s_step = settling_time(
            log.t, states[:, moved], final[moved], 0.1 * step[moved], t_from=t_move
        )
        print(
            f"  {name:<16} within 10 % of the final values after {s10:6.1f} s; "
            f"within 10 % of the step after {s_step:6.1f} s"
        )
    # what it buys in odometry: windows starting in the first 60 s of asphalt driving
    win = spatial_windows(log)
    start_t = log.t[win.start]
    mask = (start_t >= t_move) & (start_t < t_move + 60.0)
    for name, states in (("with P_B reset", with_reset), ("without reset", without)):
        icr = [states[:, i] for i in range(states.shape[1])]
        e = window_errors(log, win, icr_twist_from_rows(win, *icr))
        print(
            f"  {name:<16} first 60 s on asphalt: {np.median(e.translation_per_m[mask]):.4f} m/m, "
            f"{np.median(e.rotation_per_m[mask]):.3f} deg/m median over {mask.sum()} windows"
        )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", default=str(REPO.parent / "shared" / "data" / "drive"))
    parser.add_argument("--config", default=str(REPO / "config" / "warthog.yaml"))
    args = parser.parse_args()
    data = Path(args.data)
    cfg = load_config(args.config)
    r, b = cfg.robot.wheel_radius, cfg.robot.track_width
    started = time.perf_counter()
    grass = [
        read_wheel_log(p, wheel_radius=r) for p in sorted(data.glob("warthog_wheels_grass*.csv"))
    ]
    asphalt = [
        read_wheel_log(data / "warthog_wheels_asphalt_2024_9_25_12h8s57.csv", wheel_radius=r)
    ]
    gw = [spatial_windows(g) for g in grass]

    print("Offline constant fits (terrain-odom fit, 2 m segments):")
    p_edd_g = fit_constant("edd-sym", grass, cfg)
    p_icr_a = fit_constant("icr-slip", asphalt, cfg)
    p_icr3_a = fit_constant("icr", asphalt, cfg)
    p_icra_g = fit_constant("edd-asym", grass, cfg)
    print(f"  edd-sym on grass:           alpha={p_edd_g[0]:.3f} b_hat={p_edd_g[1]:.3f} m")
    print(
        f"  edd-asym on grass:          {np.array2string(p_icra_g, precision=3)}"
        "  (alpha_l, alpha_r, x_v, y_l, y_r)"
    )
    print(
        f"  icr-slip on asphalt (prior): {np.array2string(p_icr_a, precision=3)}"
        "  (y_l, y_r, x_icr, alpha)"
    )
    print(f"  icr on asphalt (prior):     {np.array2string(p_icr3_a, precision=3)}")

    print(
        f"\nGrass, five runs pooled, h_e = {cfg.evaluation.horizon:g} m:"
        f"{'m/m median [q25-q75]':>37}  deg/m median [q25-q75]"
    )
    line(
        f"ideal differential drive, B = {b:g} m",
        [
            window_errors(g, w, model_twist(get_model("idd"), [], b))
            for g, w in zip(grass, gw, strict=True)
        ],
    )
    line(
        "edd-sym fitted on these grass runs (oracle)",
        [
            window_errors(g, w, model_twist(get_model("edd-sym"), p_edd_g))
            for g, w in zip(grass, gw, strict=True)
        ],
    )
    line(
        "edd-asym fitted on these grass runs (oracle)",
        [
            window_errors(g, w, model_twist(get_model("edd-asym"), p_icra_g))
            for g, w in zip(grass, gw, strict=True)
        ],
    )
    line(
        "icr-slip fitted on asphalt (the EKF's prior)",
        [
            window_errors(g, w, model_twist(get_model("icr-slip"), p_icr_a))
            for g, w in zip(grass, gw, strict=True)
        ],
    )
    line(f"EKF {Path(args.config).name} (alpha state, asphalt prior)", ekf_errors(grass, gw, cfg))
    no_alpha = with_ekf(cfg, estimate_alpha=False, initial=IcrState(*p_icr3_a, 1.0))
    line("EKF without alpha state (asphalt icr prior)", ekf_errors(grass, gw, no_alpha))
    nominal = with_ekf(cfg, initial=IcrState(b / 2, -b / 2, 0.0, 1.0))
    line(
        f"EKF from nominal geometry (y = +-{b / 2:g} m, alpha = 1)", ekf_errors(grass, gw, nominal)
    )
    line(
        "EKF from nominal geometry, without alpha",
        ekf_errors(grass, gw, with_ekf(nominal, estimate_alpha=False)),
    )

    reconvergence(cfg, data, "EKF with alpha")
    reconvergence(with_ekf(cfg, estimate_alpha=False), data, "The paper's 6-state EKF (no alpha)")
    print(f"\n({time.perf_counter() - started:.0f} s)")


if __name__ == "__main__":
    main()

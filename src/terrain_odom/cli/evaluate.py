"""``terrain-odom evaluate``: model-odometry error per metre and ATE."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``evaluate`` subcommand."""
    p = sub.add_parser("evaluate", help="model-odometry error per metre and ATE")
    p.add_argument("--log", required=True, help="wheel log CSV with pose measurements")
    p.add_argument("--run", help="output directory of 'terrain-odom run' on this log")
    p.add_argument("--params", nargs="*", default=[], help="parameter files of constant models")
    p.add_argument("--config", help="YAML configuration (robot geometry, horizon)")
    p.add_argument("--horizon", type=float, help="evaluation horizon h_e in metres (default 2)")
    p.add_argument("--out", help="JSON output (default RUN/evaluation.json)")
    add_pose_delay_option(p)
    p.set_defaults(func=_cmd_evaluate)


def add_pose_delay_option(p: argparse.ArgumentParser) -> None:
    """Add ``--pose-delay {auto,SECONDS}`` (overrides the configuration's ``time.pose_delay``)."""
    p.add_argument(
        "--pose-delay",
        metavar="{auto,SECONDS}",
        help="the pose stamps lag the wheel speeds by this many seconds (the wheel speeds are "
        "delayed to match), or auto: estimate it from the whole log's heading (offline "
        "calibration); default: the configuration's time.pose_delay, 0",
    )


def pose_delay_line(timing: dict) -> str:
    """One line on the pose delay applied (a ``TimeCalibration.to_dict()``)."""
    line = f"pose delay: {timing['pose_delay_s']:.3f} s"
    if timing["estimated"]:
        line += (
            f" (estimated, +-{timing['std_s']:.3f} s, from {timing['heading_changes']} "
            "heading changes)"
        )
    return line


def _format_stats(entry: dict) -> str:
    t, r = entry["translation_m_per_m"], entry["rotation_deg_per_m"]
    ate = entry["ate_dead_reckoning"]["rmse_m"]

    def fmt(v: float | None, digits: int) -> str:
        return "n/a" if v is None else f"{v:.{digits}f}"

    return (
        f"{fmt(t['median'], 4):>8} [{fmt(t['q25'], 3)}-{fmt(t['q75'], 3)}]"
        f"  {fmt(r['median'], 3):>7} [{fmt(r['q25'], 2)}-{fmt(r['q75'], 2)}]"
        f"  {fmt(ate, 2):>8}"
    )


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from terrain_odom.app.evaluate import evaluate
    from terrain_odom.config import load_config, with_pose_delay
    from terrain_odom.estimation.time_offset import shows_pose_delay

    result = evaluate(
        args.run,
        args.log,
        config=with_pose_delay(load_config(args.config), args.pose_delay),
        config_path=args.config,
        params=args.params,
        horizon=args.horizon,
        out=args.out,
    )
    print(f"{result['windows']} windows of {result['horizon_m']:g} m on {result['log']}")
    timing = result["time_calibration"]
    if shows_pose_delay(timing):
        print(pose_delay_line(timing))
    print(f"{'model':<32} {'m/m median [q25-q75]':>24}  {'deg/m median [q25-q75]':>22}  ATE DR (m)")
    for name, entry in result["models"].items():
        print(f"{name:<32} {_format_stats(entry)}")
    ahead = result["prediction_2s"]
    print()
    print(
        f"2-s prediction from {ahead['windows']} measured poses: mean position (m), heading (deg)"
    )
    for name, entry in ahead["models"].items():
        pos, head = entry["position_m"], entry["heading_deg"]
        shown = "n/a" if pos is None else f"{pos:8.3f}  {head:8.2f}"
        print(f"{name:<32} {shown}")
    return 0

"""``terrain-odom inspect``: list a bag's topics and the roles they can play here."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``inspect`` subcommand."""
    p = sub.add_parser(
        "inspect",
        help="list a ROS bag's topics: type, count, rate, span and role (wheels, pose, ...)",
    )
    p.add_argument("bag", metavar="BAG", help="ROS 1 .bag file, ROS 2 bag folder or .mcap file")
    p.set_defaults(func=_cmd_inspect)


def _cmd_inspect(args: argparse.Namespace) -> int:
    from terrain_odom.io.bag.reader import short_type, summarize_bag

    summary = summarize_bag(args.bag)
    span = (
        (summary.end_ns - summary.start_ns) / 1e9
        if summary.start_ns is not None and summary.end_ns is not None
        else 0.0
    )
    print(f"bag:      {summary.path} ({summary.kind})")
    print(f"messages: {summary.messages} over {span:.1f} s")
    rows = [("topic", "type", "count", "rate Hz", "span s", "roles")]
    for t in summary.topics:
        rate = f"{t.rate:.1f}" if t.rate is not None else "-"
        roles = ", ".join(t.roles) or "-"
        rows.append(
            (t.topic, short_type(t.msgtype), str(t.count), rate, f"{t.duration:.1f}", roles)
        )
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for r in rows:
        print("  ".join(cell.ljust(w) for cell, w in zip(r, widths, strict=True)).rstrip())
    return 0

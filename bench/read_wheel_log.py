"""Reading a wheel log against bare ``csv`` parsing of the same file.

Writes a 100,000-row wheel log (100 Hz, a pose row in ten, 100 segments),
then times :func:`terrain_odom.io.wheel_log.read_wheel_log` and
``list(csv.reader(...))`` on it, best of ``--repeat``, and prints both and
their ratio: the conversion is vectorised, so reading costs a few times the
bare parsing (about 5x or less on an idle machine).

Usage::

    python bench/read_wheel_log.py [--rows 100000] [--repeat 5]
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from terrain_odom.io.wheel_log import read_wheel_log


def write_log(path: Path, n: int) -> None:
    """Write an ``n``-row wheel log with a pose row in ten and a segment per 1000 rows."""
    t = np.arange(n) * 0.01
    speeds = np.round(np.sin(t), 6)
    with open(path, "w") as handle:
        handle.write("t,omega_l,omega_r,x,y,yaw,terrain,segment\n")
        handle.writelines(
            f"{t[k]:.2f},{speeds[k]},{-speeds[k]},"
            + (f"{k * 1e-3},{-k * 1e-3},0.5" if k % 10 == 0 else ",,")
            + f",grass,{k // 1000}\n"
            for k in range(n)
        )


def best_time(function: Callable[[], object], repeat: int) -> float:
    """Return the shortest of ``repeat`` wall-clock times of ``function()``, s."""
    durations = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        durations.append(time.perf_counter() - start)
    return min(durations)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=100_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.csv"
        write_log(path, args.rows)

        def bare_csv() -> None:
            with open(path, newline="") as handle:
                list(csv.reader(handle))

        read = best_time(lambda: read_wheel_log(path, wheel_radius=0.3), args.repeat)
        bare = best_time(bare_csv, args.repeat)
    print(f"{args.rows} rows: read_wheel_log {read * 1e3:.1f} ms, csv.reader {bare * 1e3:.1f} ms")
    print(f"ratio {read / bare:.2f}x bare csv parsing")


if __name__ == "__main__":
    main()

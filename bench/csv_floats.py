"""Ways to write a block of floats exactly, against the shortest ``repr``.

Formats a block of 4096 rows x 15 float columns (random normal values, as
the state and standard-deviation columns of ``trajectory.csv``) as CSV text
in several ways and prints each as microseconds per row and as a ratio to
``repr`` per float, best of ``--repeat``. Every way shown round-trips
exactly (``float(text) == value``, checked). ``by_writer`` is what
``TrajectoryWriter.write_block`` does (orjson's Ryu digits, a column at a
time: shortest digits, the notation may differ from ``repr``'s).

Usage::

    python bench/csv_floats.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from terrain_odom.io.trajectory import _float_texts

ROWS, COLUMNS = 4096, 15


def by_repr(block: np.ndarray) -> str:
    """Each column with ``float.__repr__`` (the writer's way), rows joined."""
    cells = [list(map(float.__repr__, column)) for column in block.T.tolist()]
    return "\n".join(map(",".join, zip(*cells, strict=True)))


def by_writer(block: np.ndarray) -> str:
    """Format as the writer does (orjson a column at a time), rows joined as it joins them."""
    cells = [_float_texts(column) for column in block.T]
    return "\n".join(map(",".join, zip(*cells, strict=True)))


def by_numpy_str(block: np.ndarray) -> str:
    """Format with numpy's ``astype(str)`` (Dragon4, shortest), rows joined."""
    return "\n".join(map(",".join, block.astype(str).tolist()))


def by_list_repr(block: np.ndarray) -> str:
    """``repr`` of the nested list (formatted in C), brackets and spaces removed."""
    return repr(block.tolist())[2:-2].replace(", ", ",").replace("],[", "\n")


def by_percent_17g(block: np.ndarray) -> str:
    """One ``%`` per row on a joined ``%.17g`` format (17 digits: exact, not shortest)."""
    row = ",".join(["%.17g"] * block.shape[1])
    return "\n".join([row % tuple(values) for values in block.tolist()])


def best(repeat: int, fn: Callable[[np.ndarray], str], block: np.ndarray) -> float:
    """Smallest time of ``fn(block)`` over ``repeat`` calls, s."""
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        fn(block)
        times.append(time.perf_counter() - started)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    block = np.random.default_rng(0).normal(size=(ROWS, COLUMNS))
    ways = (by_repr, by_writer, by_numpy_str, by_list_repr, by_percent_17g)
    for fn in ways:  # every way is exact
        text = fn(block)
        back = np.array([line.split(",") for line in text.split("\n")], dtype=float)
        assert np.array_equal(back, block), fn.__name__
    baseline = best(args.repeat, by_repr, block)
    print(f"{ROWS} rows x {COLUMNS} floats, best of {args.repeat}")
    for fn in ways:
        seconds = baseline if fn is by_repr else best(args.repeat, fn, block)
        size = len(fn(block)) / ROWS
        print(
            f"  {fn.__name__:16s} {1e6 * seconds / ROWS:6.2f} us/row = {seconds / baseline:4.2f}x "
            f"repr, {size:5.1f} bytes/row"
        )


if __name__ == "__main__":
    main()

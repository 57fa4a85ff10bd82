"""Speed of the ICR EKF and of the whole ``terrain-odom run``, as ratios to baselines of the same run.

Builds a long real log by concatenating the Warthog drive logs of
``../shared/data/drive`` ``--copies`` times (each piece its own segment; by
default 3 x 54 414 = 163 242 rows, 2.3 h at 20 Hz) into ``--work`` (never into
the repository), then prints, each figure with the baseline it is divided by:

1. **filter per wheel sample**: ``IcrEkf.predict`` at every row and
   ``update`` at every pose, over ``--rows`` rows of the long log, for the
   compiled kernels, the filterpy reference (``FilterpyIcrEkf``, the
   formulation before the kernels) and the same maths in numpy without
   filterpy; the speed-up and the largest state difference to the reference;
2. **whole run**: ``terrain-odom run`` on the long log (a fresh process, so
   start-up included) against pandas reading and writing the same CSV
   (``read_csv`` + ``to_csv``, pandas already imported), alternately, best of
   ``--repeat`` each; and where the time goes (in-process: reading, checks
   and pose delay, filter loop, writing);
3. **start-up**: ``terrain-odom run`` on the first 200 rows, with and
   without its plots, against ``python -c "import numpy"``, and the plots'
   floor: importing the matplotlib modules they need and nothing else
   (alternately, best of 3 x ``--repeat`` fresh processes each: a start-up
   is short, its minimum needs more rounds), the package byte-compiled
   first as an installed one is (under ``PYTHONDONTWRITEBYTECODE=1`` a
   source checkout would otherwise compile its ~70 modules at every start);
   then, in one more fresh process, where the plots' time goes (the filter,
   importing matplotlib, and each figure's build, layout, draw and PNG);
   whether scikit-learn, ``scipy.stats``, filterpy, numba or matplotlib
   were imported;
4. **memory**: peak resident memory of ``terrain-odom run`` on one copy and
   on ``--copies`` copies, and the growth per row; the same with
   ``--no-plots``; and each run's peak of traced allocations (``tracemalloc``:
   Python objects and numpy buffers), which grows with the log's rows alone
   (the resident peak also holds the libraries, and varies by some MiB);
   then the traced peak during and memory held after each step of the run
   (reading; loop and writing), per extra row (about 3 min in all).

Usage::

    python bench/ekf_speed.py [--data ../shared/data/drive] [--copies 3] [--rows 20000]
                              [--repeat 3] [--work /tmp/bench_ekf_speed]

About 2 minutes on the 2-core machine (the filterpy reference takes most).
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import terrain_odom
from terrain_odom.config import Config, load_config
from terrain_odom.estimation import IcrEkf, icr_step_with_jacobian
from terrain_odom.estimation._kernel_switch import compile_kernels
from terrain_odom.estimation.icr_ekf_reference import FilterpyIcrEkf
from terrain_odom.io import read_wheel_log, write_wheel_log
from terrain_odom.records import WheelLog

REPO = Path(__file__).resolve().parents[1]
CONFIG = REPO / "config" / "warthog.yaml"
EXE = [sys.executable, "-m", "terrain_odom"]


def best_of(repeat: int, *fns: Callable[[], object]) -> list[float]:
    """Smallest wall time of each of ``fns`` over ``repeat`` rounds, s.

    The calls alternate (one of each per round), so a change of the
    machine's load affects the figure and its baseline alike.
    """
    times: list[list[float]] = [[] for _ in fns]
    for _ in range(repeat):
        for fn, spent in zip(fns, times, strict=True):
            started = time.perf_counter()
            fn()
            spent.append(time.perf_counter() - started)
    return [min(spent) for spent in times]


def long_log(data: Path, copies: int, path: Path) -> int:
    """Write the drive logs of ``data``, ``copies`` times over, as one log; return its rows."""
    logs = [read_wheel_log(p, wheel_radius=0.30) for p in sorted(data.glob("*.csv"))] * copies
    segments, offset = [], 0
    for log in logs:
        segments.append(log.segment - log.segment.min() + offset)
        offset = int(segments[-1].max()) + 1

    def cat(field: Callable[[WheelLog], np.ndarray]) -> np.ndarray:
        return np.concatenate([field(log) for log in logs])

    joined = WheelLog(
        cat(lambda g: g.t),
        cat(lambda g: g.v_l),
        cat(lambda g: g.v_r),
        cat(lambda g: g.pose),
        cat(lambda g: g.terrain),
        np.concatenate(segments),
        source=str(path),
    )
    write_wheel_log(path, joined)
    return len(joined)


# ----------------------------------------------------------- 1. per sample
class NumpyIcrEkf(IcrEkf):
    """The predict in plain numpy without filterpy (an alternative; update compiled)."""

    def predict(self, v_l: float, v_r: float, dt: float) -> None:
        """Propagate over one wheel sample: the ICR step, ``F P F^T + Q dt``."""
        x, jac = icr_step_with_jacobian(self._x, v_l, v_r, dt)
        p = jac @ self._P @ jac.T + np.diag(self._q_density * dt)
        self._x[:], self._P[:] = x, 0.5 * (p + p.T)
        self.t += dt


def filter_loop(ekf: IcrEkf, log: WheelLog, rows: int) -> float:
    """Predict at every row and update at every pose of the first ``rows`` rows; return s."""
    t, v_l, v_r = log.t[:rows].tolist(), log.v_l[:rows].tolist(), log.v_r[:rows].tolist()
    poses = log.pose[:rows]
    has = np.isfinite(poses).any(axis=1).tolist()
    new = np.zeros(rows, dtype=bool)
    new[log.run_starts()[log.run_starts() < rows]] = True
    new_segment = new.tolist()
    started = time.perf_counter()
    for k in range(1, rows):
        if not new_segment[k]:
            ekf.predict(v_l[k - 1], v_r[k - 1], t[k] - t[k - 1])
        if has[k]:
            ekf.update(poses[k])
    return time.perf_counter() - started


def per_sample(log: WheelLog, cfg: Config, rows: int) -> None:
    """Section 1: the filter alone, per wheel sample."""
    rows = min(rows, len(log))
    n_poses = int(np.isfinite(log.pose[:rows]).any(axis=1).sum())
    compile_kernels()  # the compiled kernels (a run's first PURE_CALLS calls run as Python)
    fast = IcrEkf(cfg.ekf)
    filter_loop(fast, log, 200)  # load the compiled kernels (cache) before timing
    fast = IcrEkf(cfg.ekf)
    ref = FilterpyIcrEkf(cfg.ekf)
    t_fast = filter_loop(fast, log, rows)
    t_ref = filter_loop(ref, log, rows)
    t_numpy = filter_loop(NumpyIcrEkf(cfg.ekf), log, rows)
    diff = float(np.max(np.abs(fast.x - ref.x)))
    us = 1e6 / rows
    print(
        f"1. filter per wheel sample ({rows} rows, {n_poses} pose updates, first rows of the log)"
    )
    print(f"   filterpy reference (baseline)   {t_ref * us:8.2f} us")
    print(
        f"   predict in numpy, no filterpy   {t_numpy * us:8.2f} us = {t_ref / t_numpy:5.1f}x faster"
    )
    print(
        f"   compiled kernels (IcrEkf)       {t_fast * us:8.2f} us = {t_ref / t_fast:5.1f}x faster"
        f" (goal <= 5 us); final state differs from the reference by {diff:.1e}"
    )


# ------------------------------------------------------------ 2. whole run
def run_cli(
    log: Path, out: Path, *options: str, stats: bool = False, traced: list[int] | None = None
) -> tuple[float, int]:
    """Run ``terrain-odom run`` (with ``options``) in a fresh process; return (wall s, peak RSS KiB).

    The peak is the process's ``VmHWM`` (``ru_maxrss`` would carry over the
    bench's own peak through fork and exec). With a list ``traced``, the run
    is traced by ``tracemalloc`` (Python objects and numpy buffers, not the
    libraries' own C memory) and its peak in bytes is appended to the list.
    """
    trace = traced is not None
    code = (
        "import re, sys, runpy, tracemalloc\n"
        + ("tracemalloc.start()\n" if trace else "")
        + f"sys.argv = ['terrain-odom', 'run', '--wheels', {str(log)!r}, '--out', {str(out)!r}, "
        f"'--config', {str(CONFIG)!r}, '--overwrite', *{list(options)!r}]\n"
        "try:\n    runpy.run_module('terrain_odom', run_name='__main__')\n"
        "except SystemExit as exc:\n    assert not exc.code, exc.code\n"
        "heavy = [m for m in ('sklearn', 'scipy.stats', 'filterpy', 'numba', 'matplotlib')"
        " if m in sys.modules]\n"
        "status = open('/proc/self/status').read()  # VmHWM: this process's own peak\n"
        "print('@@', re.search(r'VmHWM:\\s+(\\d+)', status)[1], ','.join(heavy) or '-',"
        " tracemalloc.get_traced_memory()[1])\n"
    )
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    seconds = time.perf_counter() - started
    marker = [line for line in done.stdout.splitlines() if line.startswith("@@")][0].split()
    if stats:
        print(
            f"   modules imported by the run: {marker[2] if marker[2] != '-' else 'none of'} "
            "(scikit-learn, scipy.stats, filterpy, numba, matplotlib)"
        )
    if traced is not None:
        traced.append(int(marker[3]))
    return seconds, int(marker[1])


def whole_run(path: Path, rows: int, work: Path, repeat: int) -> None:
    """Section 2: the whole run against pandas reading and writing the same CSV.

    Also against pandas reading the log and writing what the run writes
    (``trajectory.csv`` and ``trajectory.tum`` of a run's results, floats
    as pandas writes them: exact, like the run): the input and output
    alone, no filter.
    """
    import pandas as pd

    from terrain_odom.app.run import RunOptions, run

    cfg = load_config(CONFIG)
    summary = run(path, work / "warm", RunOptions(config=cfg, progress=False, overwrite=True))
    written = pd.read_csv(summary.trajectory_csv)
    tum = pd.read_csv(summary.trajectory_tum, sep=" ", comment="#", header=None)

    def pandas_io() -> None:
        pd.read_csv(path).to_csv(work / "pandas.csv", index=False)

    def pandas_outputs() -> None:
        pd.read_csv(path)
        written.to_csv(work / "pandas_trajectory.csv", index=False)
        tum.to_csv(work / "pandas.tum", sep=" ", header=False, index=False)

    t_pandas, t_outputs, t_run, t_bare = best_of(
        repeat,
        pandas_io,
        pandas_outputs,
        lambda: run_cli(path, work / "run"),
        lambda: run_cli(path, work / "run", "--no-plots"),
    )
    print(f"2. whole run on the long log ({rows} rows), best of {repeat}")
    print(f"   pandas read_csv + to_csv of the log (baseline)   {t_pandas:6.2f} s")
    print(
        f"   pandas read_csv of the log + to_csv of the run's two outputs {t_outputs:6.2f} s = "
        f"{t_outputs / t_pandas:4.1f}x pandas"
    )
    for what, seconds in (("", t_run), (" --no-plots", t_bare)):
        print(
            f"   terrain-odom run{what:11s} (fresh)  {seconds:6.2f} s = "
            f"{seconds / t_pandas:4.1f}x pandas (goal <= 4x) = "
            f"{seconds / t_outputs:4.1f}x pandas's input + output = {1e6 * seconds / rows:.1f} us/row"
        )
    started = time.perf_counter()
    summary = run(path, work / "inproc", RunOptions(config=cfg, progress=False, overwrite=True))
    total = time.perf_counter() - started
    report = json.loads(summary.report_json.read_text())
    print(f"   in-process run {total:.2f} s ({report['counts']['updates']} updates); its parts:")
    breakdown(path, cfg, rows, work)


def breakdown(path: Path, cfg: Config, rows: int, work: Path) -> None:
    """Time the parts of a run separately: read, check + pose delay, filter, write."""
    from terrain_odom.app.inputs import calibrate_log
    from terrain_odom.estimation.odometry import run_icr_ekf
    from terrain_odom.io import TrajectoryWriter
    from terrain_odom.io.trajectory import TrajectoryBlocks, TumWriter, trajectory_columns

    parts: dict[str, float] = {}
    started = time.perf_counter()
    log = read_wheel_log(path, wheel_radius=cfg.robot.wheel_radius)
    parts["read the log"] = time.perf_counter() - started
    started = time.perf_counter()
    log, _ = calibrate_log(log, cfg)
    parts["plausibility checks + pose delay"] = time.perf_counter() - started
    started = time.perf_counter()
    result = run_icr_ekf(log, cfg, labels=log.terrain)
    parts["filter loop (compiled stretches)"] = time.perf_counter() - started
    started = time.perf_counter()
    with (
        TrajectoryWriter(work / "t.csv", trajectory_columns(result.names)) as writer,
        TumWriter(work / "t.tum") as tum,
    ):
        blocks = TrajectoryBlocks(writer, result.names, tum)
        for start in range(0, len(log), 4096):
            rows_ = slice(start, start + 4096)
            blocks.write(
                log.t[rows_], result.states[rows_], result.stds[rows_], result.terrain[rows_]
            )
    parts["write trajectory.csv + .tum (blocks)"] = time.perf_counter() - started
    started = time.perf_counter()
    for column in (log.t, *result.states.T, *result.stds.T):
        list(map(float.__repr__, column.tolist()))
    parts["  of which repr() of the csv's floats"] = time.perf_counter() - started
    for name, seconds in parts.items():
        print(f"     {name:40s} {seconds:6.2f} s = {1e6 * seconds / rows:5.1f} us/row")


# ------------------------------------------------------ 3. start-up, 4. memory
MATPLOTLIB = "import matplotlib.figure, matplotlib.backends.backend_agg"
"""What drawing a run's plots imports at least (``reporting.figure``: no pyplot)."""


PLOT_PARTS = """
import io, sys, time
import numpy as np
from PIL import Image
from terrain_odom.config import load_config
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.io import read_wheel_log
cfg = load_config(sys.argv[2])
log = read_wheel_log(sys.argv[1], wheel_radius=cfg.robot.wheel_radius)
laps = [time.perf_counter()]
result = run_icr_ekf(log, cfg, labels=log.terrain)
def lap():
    laps.append(time.perf_counter())
    return f"{1e3 * (laps[-1] - laps[-2]):4.0f} ms"
print(f"   in one fresh process: the filter over the 200 rows {lap()} (its Python kernels)")
import matplotlib.figure, matplotlib.backends.backend_agg
print(f"   importing matplotlib (figure, Agg) {lap()}")
from terrain_odom.reporting.plots import states_figure, trajectory_figure
lap()
for name, draw in (("trajectory", lambda: trajectory_figure(log, result)),
                   ("states", lambda: states_figure(log.t, result))):
    fig = draw()
    build = lap()
    fig.get_layout_engine().execute(fig)
    layout = lap()
    fig.set_layout_engine("none")
    fig.canvas.draw()
    render = lap()
    Image.fromarray(np.asarray(fig.canvas.buffer_rgba())).save(io.BytesIO(), format="png")
    print(f"   {name:10s} figure: build {build}, layout {layout}, draw {render}, PNG {lap()}")
"""
"""Where a 200-row run's plots spend their time, figure by figure (``reporting.plots``)."""


def startup(path: Path, work: Path, repeat: int) -> None:
    """Section 3: a 200-row run against importing numpy (and matplotlib), fresh processes."""
    short = work / "short200.csv"
    short.write_text("".join(path.read_text().splitlines(keepends=True)[:201]))
    package = Path(terrain_odom.__file__).parent
    compileall.compile_dir(package, quiet=1)  # as pip install does; a no-op once compiled
    run_cli(short, work / "short")  # compile or load the kernels' cache once

    def python_c(code: str) -> Callable[[], object]:
        return lambda: subprocess.run([sys.executable, "-c", code], check=True)

    rounds = 3 * repeat
    names = ("python -c 'import numpy' (baseline)", "terrain-odom run, 200 rows",
             "terrain-odom run, 200 rows --no-plots", "matplotlib's import alone (*)")  # fmt: skip
    jobs = (python_c("import numpy"), lambda: run_cli(short, work / "short"),
            lambda: run_cli(short, work / "short", "--no-plots"), python_c(MATPLOTLIB))  # fmt: skip
    wall = best_of(rounds, *jobs)
    print(f"3. start-up, best of {rounds} fresh processes (goal <= 4x numpy)")
    for name, seconds in zip(names, wall, strict=True):
        print(f"   {name:38s} {seconds:6.3f} s = {seconds / wall[0]:4.1f}x numpy")
    print(f"   the plots: {wall[1] - wall[2]:.3f} s")
    print(f"   (*) python -c '{MATPLOTLIB}': the plots' floor")
    print(subprocess.run([sys.executable, "-c", PLOT_PARTS, str(short), str(CONFIG)],
                         capture_output=True, text=True, check=True).stdout, end="")  # fmt: skip
    run_cli(short, work / "short", stats=True)
    run_cli(short, work / "short", "--no-plots", stats=True)


def memory(data: Path, copies: int, path: Path, rows: int, work: Path) -> None:
    """Section 4: peak memory on one copy and on ``copies`` copies of the drive logs."""
    one = work / "one_copy.csv"
    rows_one = long_log(data, 1, one)
    extra = rows - rows_one
    print("4. peak memory of terrain-odom run: resident (VmHWM), then traced (tracemalloc)")
    for options in ((), ("--no-plots",)):
        rss = [run_cli(log, work / "mem", *options)[1] for log in (one, path)]
        traced: list[int] = []
        for log in (one, path):
            run_cli(log, work / "mem", *options, traced=traced)
        name = " ".join(options) or "with plots"
        print(f"   {name}:")
        for n, kib, peak in zip((rows_one, rows), rss, traced, strict=True):
            print(f"   {n:7d} rows  {kib / 1024:6.1f} MiB resident  {peak / 2**20:6.1f} MiB traced")
        print(
            f"   growth per row: {1024 * (rss[1] - rss[0]) / extra:.0f} B resident, "
            f"{(traced[1] - traced[0]) / extra:.0f} B traced"
        )
    memory_steps(one, path, extra, work)


STEPS = ("read the log, checks, pose delay", "filter loop, trajectory.csv and .tum")


def traced_steps(log: Path, out: Path) -> list[tuple[int, int]]:
    """Run ``run`` in-process (``--no-plots``) under ``tracemalloc``; per step of :data:`STEPS`.

    Returns the traced (peak during the step, current after it) in bytes.
    """
    import tracemalloc

    from terrain_odom.app import run as app_run

    marks: list[tuple[int, int]] = []

    def timed(fn: Callable[..., object]) -> Callable[..., object]:
        def wrapper(*args: object, **kwargs: object) -> object:
            tracemalloc.reset_peak()
            value = fn(*args, **kwargs)
            current, peak = tracemalloc.get_traced_memory()
            marks.append((peak, current))
            return value

        return wrapper

    saved = {name: getattr(app_run, name) for name in ("_read_inputs", "stream_log")}
    for name, fn in saved.items():
        setattr(app_run, name, timed(fn))
    tracemalloc.start()
    try:
        options = app_run.RunOptions(
            config_path=CONFIG, overwrite=True, plots=False, progress=False
        )
        app_run.run(log, out, options)
    finally:
        tracemalloc.stop()
        for name, fn in saved.items():
            setattr(app_run, name, fn)
    return marks


def memory_steps(one: Path, path: Path, extra: int, work: Path) -> None:
    """Print the traced peak and held memory per step, B per extra row of the long log."""
    traced_steps(one, work / "steps1")  # warm-up: imports and caches are not the log's
    small, large = traced_steps(one, work / "steps1"), traced_steps(path, work / "steps")
    print("   per step (in-process, --no-plots), B per extra row: peak during / held after")
    for name, a, b in zip(STEPS, small, large, strict=True):
        print(f"   {name:<36} {(b[0] - a[0]) / extra:5.0f} / {(b[1] - a[1]) / extra:5.0f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data" / "drive")
    parser.add_argument("--copies", type=int, default=3)
    parser.add_argument("--rows", type=int, default=20000, help="rows for the per-sample figure")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--work", type=Path, default=Path("/tmp/bench_ekf_speed"))
    parser.add_argument("--sections", default="1234", help="sections to run, e.g. 34")
    args = parser.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    path = args.work / "long.csv"
    rows = long_log(args.data, args.copies, path)
    print(f"long log: {path} ({rows} rows); load average {os.getloadavg()}")
    cfg = load_config(CONFIG)
    if "1" in args.sections:
        per_sample(read_wheel_log(path, wheel_radius=0.30), cfg, args.rows)
    if "2" in args.sections:
        whole_run(path, rows, args.work, args.repeat)
    if "3" in args.sections:
        startup(path, args.work, args.repeat)
    if "4" in args.sections:
        memory(args.data, args.copies, path, rows, args.work)
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()

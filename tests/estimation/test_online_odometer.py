"""Camera runs between frames: compiled rows with the arrival odometer on, equal to the calls."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom import OnlineOdometry
from terrain_odom.app.inputs import read_calibrated_log
from terrain_odom.config import Config, load_config
from terrain_odom.estimation.icr_ekf import IcrEkf
from terrain_odom.estimation.terrain import TerrainFlow
from terrain_odom.records import Sighting, WheelLog

ROWS_PER_FRAME = 5  # wheels at 50 Hz, frames at 10 Hz


def _sightings(n_frames: int) -> list[Sighting]:
    """Grass ahead, gravel from frame 40 to 99, grass again, with two single misreadings."""
    labels = ["gravel" if 40 <= i < 100 else "grass" for i in range(n_frames)]
    labels[20] = labels[130] = "gravel"  # a misreading, not confirmed
    return [Sighting(label, 2.0 + 0.5 * np.sin(i / 7.0)) for i, label in enumerate(labels)]


def _camera_run(odo: OnlineOdometry, log: WheelLog, by_rows: bool) -> np.ndarray:
    """Feed ``log`` (one segment) with a sighting every few rows; the states after every row.

    ``by_rows``: stretches between sightings through :meth:`OnlineOdometry.rows`;
    otherwise :meth:`~OnlineOdometry.wheels`, :meth:`~OnlineOdometry.pose` row by row.
    """
    sightings = _sightings(len(log) // ROWS_PER_FRAME)
    states = []
    for i, start in enumerate(range(0, len(log), ROWS_PER_FRAME)):
        rows = slice(start, start + ROWS_PER_FRAME)
        if by_rows:
            got = odo.rows(log.t[rows], log.v_l[rows], log.v_r[rows], log.pose[rows],
                           new_segment=start == 0)  # fmt: skip
            states.append(np.hstack(got[:2]))
        else:
            for k in range(rows.start, min(rows.stop, len(log))):
                odo.wheels(float(log.t[k]), float(log.v_l[k]), float(log.v_r[k]),
                           new_segment=k == 0)  # fmt: skip
                if np.isfinite(log.pose[k]).any():
                    odo.pose(float(log.t[k]), *log.pose[k].tolist())
                states.append(np.hstack(odo.estimate())[None])
        if i < len(sightings):
            odo.sighting(float(log.t[min(rows.stop, len(log)) - 1]), sightings[i])
    return np.vstack(states)


def _compare(log: WheelLog, config: Config, monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Run ``log`` both ways; assert equal states, odometer and changes; the compiled calls' rows."""
    in_one_call: list[int] = []
    run_rows = IcrEkf.run_rows

    def counted(self, since, t, *args):  # type: ignore[no-untyped-def]
        in_one_call.append(len(t))
        return run_rows(self, since, t, *args)

    monkeypatch.setattr(IcrEkf, "run_rows", counted)
    by_rows, by_calls = OnlineOdometry(config), OnlineOdometry(config)
    fast = _camera_run(by_rows, log, by_rows=True)
    slow = _camera_run(by_calls, log, by_rows=False)
    assert len(in_one_call) > 0
    np.testing.assert_array_equal(fast, slow)
    assert by_rows.odometer == by_calls.odometer > 10.0  # the same sums, the odometer on
    assert [c.label for c in by_rows.changes] == ["gravel", "grass"]
    assert by_rows.changes == by_calls.changes  # the same arrival: time, confirmation
    assert all(c.t_confirmed is not None and c.t_confirmed < c.t for c in by_rows.changes)
    assert by_rows.n_updates == by_calls.n_updates
    assert by_rows.pose_use == by_calls.pose_use
    return in_one_call


@pytest.mark.parametrize("kernels", ["python", "compiled"], indirect=True)
def test_a_camera_run_takes_the_compiled_rows_with_the_odometer_on(kernels, monkeypatch):
    """Sightings ahead switch the odometer on; rows still go in one call, the same bits."""
    t = np.arange(900) * 0.02
    v_l, v_r = 0.8 + 0.3 * np.sin(t / 1.3), 0.8 + 0.3 * np.cos(t / 0.9)
    pose = np.full((t.size, 3), np.nan)
    pose[::5] = np.column_stack([0.8 * t, 0.1 * np.sin(t), 0.1 * np.cos(t)])[::5]
    log = WheelLog(t, v_l, v_r, pose, None, np.zeros(t.size, int), "sim")
    in_one_call = _compare(log, Config(), monkeypatch)
    # All but the first rows (before the anchoring) and those with a change pending.
    assert sum(in_one_call) > 0.6 * len(log)


def test_a_camera_run_on_a_real_log_takes_the_compiled_rows(drive_dir, warthog_yaml, monkeypatch):
    """1500 rows of the grass log (it moves from row 1661) with sightings ahead: as the calls."""
    config = load_config(warthog_yaml)
    log = read_calibrated_log(drive_dir / "warthog_wheels_grass.csv", config)[0]
    rows = slice(1600, 3100)
    log = WheelLog(log.t[rows], log.v_l[rows], log.v_r[rows], log.pose[rows], None,
                   np.zeros(1500, dtype=log.segment.dtype), log.source)  # fmt: skip
    in_one_call = _compare(log, config, monkeypatch)
    assert sum(in_one_call) > 0.6 * len(log)


def test_the_odometer_over_rows_is_its_sum_step_by_step():
    """travel_rows adds each step's model speed times its length, in order: travel's floats."""
    rng = np.random.default_rng(5)
    n = 400
    dt = rng.uniform(1e-3, 0.1, n)
    speeds = (rng.normal(0.5, 1.0, n), rng.normal(0.5, 1.0, n))
    params = np.column_stack([rng.uniform(0.3, 0.6, n), rng.uniform(-0.6, -0.3, n),
                              rng.normal(0.0, 0.1, n), rng.uniform(0.8, 1.0, n)])  # fmt: skip
    ekf = OnlineOdometry(Config())._steps.filter
    whole, steps = TerrainFlow(ekf, Config()), TerrainFlow(ekf, Config())
    whole.travelled = steps.travelled = 3.25
    whole.travel_rows(dt, speeds, params)
    assert whole.travelled == 3.25  # the odometer off: nothing moves
    whole.odometer_on = steps.odometer_on = True
    whole.travel_rows(dt, speeds, params)
    for k in range(n):
        v_x, v_y = _twist(speeds[0][k], speeds[1][k], params[k])
        steps.travel(float(np.hypot(v_x, v_y)) * float(dt[k]))
    assert whole.travelled == steps.travelled
    assert whole.travelled > 3.25 + 0.5 * float(np.sum(dt))  # moved by the speeds' order


def _twist(v_l: float, v_r: float, params: np.ndarray) -> tuple[float, float]:
    """v_x and v_y of the track-ICR model (Chen eq. 3), in Python floats."""
    y_l, y_r, x_icr, alpha = params.tolist()
    d = y_l - y_r
    omega = alpha * (v_r - v_l) / d
    return alpha * (v_r * y_l - v_l * y_r) / d, -omega * x_icr


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_sightings_and_breaks_give_the_calls_bits(seed):
    """Sightings at any distance (0, behind, far, none), segment breaks, gaps: rows() == calls."""
    rng = np.random.default_rng(seed)
    n = 600
    t = np.cumsum(rng.uniform(0.005, 0.05, n))
    v_l, v_r = rng.normal(0.8, 0.4, n), rng.normal(0.8, 0.4, n)
    pose = np.full((n, 3), np.nan)
    every = rng.random(n) < 0.2
    pose[every] = np.column_stack([0.5 * t, 0.2 * np.sin(t), 0.3 * np.cos(t)])[every]
    pose[rng.random(n) < 0.05, :2] = np.nan  # heading only
    breaks = np.sort(rng.choice(np.arange(50, n), 2, replace=False))
    t[breaks[1] :] -= 5.0  # the clock restarts at the second break
    cuts = np.unique(np.r_[0, breaks, np.sort(rng.choice(np.arange(1, n), 80)), n])
    aheads = [0.0, -1.0, 0.3, 2.5, 40.0]
    events = [
        (str(rng.choice(["grass", "gravel", "sand"], p=[0.6, 0.3, 0.1])), float(rng.choice(aheads)))
        for _ in cuts[:-1]
    ]
    results = []
    for by_rows in (True, False):
        odo = OnlineOdometry(Config())
        states = []
        spans = zip(cuts[:-1], cuts[1:], strict=True)
        for (start, stop), (label, ahead) in zip(spans, events, strict=True):
            new = bool(start == 0 or start in breaks)
            if by_rows:
                got = odo.rows(t[start:stop], v_l[start:stop], v_r[start:stop],
                               pose[start:stop], new_segment=new)  # fmt: skip
                states.append(np.hstack(got[:2]))
            else:
                for k in range(start, stop):
                    odo.wheels(float(t[k]), float(v_l[k]), float(v_r[k]),
                               new_segment=new and k == start)  # fmt: skip
                    if np.isfinite(pose[k]).any():
                        odo.pose(float(t[k]), *pose[k].tolist())
                    states.append(np.hstack(odo.estimate())[None])
            odo.sighting(float(t[stop - 1]), Sighting(label, ahead))
        results.append((np.vstack(states), odo.odometer, odo.changes, odo.pose_use))
    (fast, odometer, changes, use), (slow, *expected) = results
    np.testing.assert_array_equal(fast, slow)
    assert [odometer, changes, use] == expected
    assert odometer > 0.0 and changes

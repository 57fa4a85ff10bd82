"""Row loop of the ICR EKF: scheduling of camera-confirmed terrain changes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from terrain_odom.config import Config
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.records import Sighting, WheelLog

SPEED = 0.5  # m/s on both tracks: straight line


def _straight_log(seconds: float = 10.0, rate: float = 50.0) -> WheelLog:
    t = np.arange(0.0, seconds + 1e-9, 1.0 / rate)
    pose = np.full((t.size, 3), np.nan)
    pose[0] = 0.0
    speed = np.full(t.size, SPEED)
    return WheelLog(t, speed, speed.copy(), pose, None, np.zeros(t.size, dtype=int), "straight")


class _Script:
    """Frame observer replaying (t, label, ahead) sightings."""

    def __init__(self, sightings: list[tuple[float, str, float]]) -> None:
        self.times = np.array([s[0] for s in sightings])
        self._sightings = sightings
        self.confirmed_labels: list[str] = []

    def feed(self, index: int, odometry: OnlineOdometry) -> None:
        t, label, ahead = self._sightings[index]
        odometry.sighting(t, Sighting(label, ahead))
        self.confirmed_labels.append(odometry.seen_terrain)


def _config(reset_at: str) -> Config:
    cfg = Config()
    ekf = dataclasses.replace(
        cfg.ekf,
        estimate_alpha=False,
        initial=dataclasses.replace(cfg.ekf.initial, y_l=0.25, y_r=-0.25, x_icr=0.0),
    )
    return dataclasses.replace(
        cfg, ekf=ekf, terrain=dataclasses.replace(cfg.terrain, reset_at=reset_at)
    )


def _frames(change_t: float, back_t: float | None = None, ahead: float = 1.0):
    """Frames at 5 Hz over 10 s: grass, then sand from change_t (then grass from back_t)."""
    out = []
    for t in np.arange(0.0, 10.0, 0.2):
        sand = t >= change_t - 1e-9 and (back_t is None or t < back_t - 1e-9)
        out.append((float(t), "sand" if sand else "grass", ahead))
    return out


@pytest.mark.parametrize("reset_at", ["arrival", "immediate"])
def test_camera_change_is_applied_on_arrival_or_at_confirmation(reset_at):
    frames = _Script(_frames(change_t=2.0, ahead=1.0))
    result = run_icr_ekf(_straight_log(), _config(reset_at), frames=frames)
    (change,) = result.changes
    assert change.label == "sand" and change.previous == "grass" and change.reset
    if reset_at == "immediate":
        # confirmed by the 2nd sand frame (t = 2.2 s), applied at once
        assert change.t == pytest.approx(2.2, abs=0.021) and change.t_confirmed is None
    else:
        # first seen 1 m ahead at t = 2.0 s; at 0.5 m/s the robot is there at t = 4.0 s
        assert change.t == pytest.approx(4.0, abs=0.021)
        assert change.t_confirmed == pytest.approx(2.2, abs=0.021)
    # frames.csv's confirmed_label is the camera's view, whatever the schedule
    assert frames.confirmed_labels[11] == "sand" and frames.confirmed_labels[10] == "grass"
    # trajectory terrain follows the applied change
    row = np.searchsorted(_straight_log().t, change.t)
    assert result.terrain[row - 2] == "grass" and result.terrain[row + 1] == "sand"


def test_pending_changes_are_applied_in_order_across_a_narrow_strip():
    # sand seen 3 m ahead from t = 2 s to 3 s only: a 0.5 m strip crossed at t = 8-9 s
    frames = _Script(_frames(change_t=2.0, back_t=3.0, ahead=3.0))
    result = run_icr_ekf(_straight_log(), _config("arrival"), frames=frames)
    assert [(c.previous, c.label) for c in result.changes] == [("grass", "sand"), ("sand", "grass")]
    assert [c.t for c in result.changes] == pytest.approx([8.0, 9.0], abs=0.021)


def test_change_seen_under_the_robot_is_applied_at_once_even_on_arrival():
    frames = _Script(_frames(change_t=2.0, ahead=0.0))
    result = run_icr_ekf(_straight_log(), _config("arrival"), frames=frames)
    assert [c.t for c in result.changes] == pytest.approx([2.2], abs=0.021)


def test_log_labels_are_applied_at_once_on_arrival():
    log = _straight_log()
    labels = np.where(log.t < 3.0, "grass", "sand")
    result = run_icr_ekf(log, _config("arrival"), labels=labels)
    # the second consecutive "sand" row confirms it
    assert [c.t for c in result.changes] == pytest.approx([3.02], abs=1e-9)


def test_kept_rows_are_every_keep_th_and_the_last_and_blocks_hold_every_row(
    drive_dir, warthog_yaml
):
    """keep=7 on a real log (two segments): kept rows equal the whole run's; blocks cover all."""
    from terrain_odom.config import load_config
    from terrain_odom.estimation.odometry import run_odometry
    from terrain_odom.io import read_wheel_log

    cfg = load_config(warthog_yaml)
    log = read_wheel_log(drive_dir / "stitched_grass_to_asphalt.csv", wheel_radius=0.30)
    whole = run_icr_ekf(log, cfg, labels=log.terrain)
    blocks = []
    kept = run_odometry(
        log, OnlineOdometry(cfg), labels=log.terrain, on_block=blocks.append, keep=7
    )
    rows = np.r_[np.arange(0, len(log), 7), len(log) - 1]
    assert whole.rows is None and kept.rows is not None
    np.testing.assert_array_equal(kept.rows, rows)
    np.testing.assert_array_equal(kept.states, whole.states[rows])
    np.testing.assert_array_equal(kept.stds, whole.stds[rows])
    np.testing.assert_array_equal(kept.terrain, whole.terrain[rows])
    assert kept.changes == whole.changes and kept.n_updates == whole.n_updates
    assert [b.start for b in blocks] == np.cumsum([0] + [b.t.size for b in blocks])[:-1].tolist()
    np.testing.assert_array_equal(np.vstack([b.states for b in blocks]), whole.states)
    np.testing.assert_array_equal(np.concatenate([b.t for b in blocks]), log.t)
    assert all(b.t.size <= 2 * 4096 for b in blocks)
    with pytest.raises(ValueError, match="keep must be >= 1"):
        run_odometry(log, OnlineOdometry(cfg), keep=0)

"""Plausibility checks on synthetic logs built just inside and just outside each threshold.

The real-log tests (``test_plausibility.py``) need ``../shared``; these need
nothing, and pin what the real logs cannot: every threshold of
:class:`~terrain_odom.evaluation.plausibility.PlausibilityLimits` (read from
the limits object, not repeated here), the gap filter, the moving time, the
wheels' travel while turning on the spot and the heading's sign. Mutation
testing found each of them could change without a test noticing.

The logs: rows every 1/8 s (exact in binary, so the 0.5 s chain of compared
pose intervals is exact), a pose on every 4th row, track width 1 m.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation.plausibility import PlausibilityLimits, check_log
from terrain_odom.kinematics import integrate, wrap_angle
from terrain_odom.records import WheelLog

LIM = PlausibilityLimits()
DT = 0.125  # s between rows
PER = 4  # rows per compared pose interval (0.5 s = LIM.span)
TRACK = 1.0  # m


def _log(v_l, v_r, pose, dt: float = DT) -> WheelLog:
    """Return a log of these rows, its poses measured on every ``PER``-th row only."""
    n = len(v_l)
    pose = np.array(pose, dtype=float)
    pose[np.arange(n) % PER != 0] = np.nan
    return WheelLog(
        np.arange(n) * dt,
        np.asarray(v_l, float),
        np.asarray(v_r, float),
        pose,
        None,
        np.zeros(n, int),
    )


def _drive(v_l, v_r, pose_speed=None):
    """Exact idd poses for the track speeds, or positions moving straight at ``pose_speed``."""
    v_l, v_r = np.asarray(v_l, float), np.asarray(v_r, float)
    n = v_l.size
    if pose_speed is None:
        pose = integrate(
            (v_l + v_r)[:-1] / 2, np.zeros(n - 1), (v_r - v_l)[:-1] / TRACK, np.full(n - 1, DT)
        )
    else:
        pose = np.c_[
            np.r_[0.0, np.cumsum(np.broadcast_to(pose_speed, n - 1) * DT)], np.zeros((n, 2))
        ]
    return _log(v_l, v_r, pose)


def _checks(log: WheelLog, limits: PlausibilityLimits = LIM) -> list[str]:
    return [f.check for f in check_log(log, TRACK, limits).findings]


def _rows(seconds: float) -> int:
    return round(seconds / DT) + 1


# ------------------------------------------------------------------ units
@pytest.mark.parametrize(("factor", "found"), [(0.99, []), (1.01, ["absurd_speed"])])
def test_absurd_speed_just_inside_and_outside(factor, found):
    v = np.full(_rows(20.0), 1.0)
    v[40] = factor * LIM.max_speed
    assert _checks(_drive(v, v)) == found


@pytest.mark.parametrize(
    ("step", "found"),
    [
        (LIM.time_step[1] * 1.01, ["time_step"]),
        (LIM.time_step[1] * 0.99, []),
        (LIM.time_step[0] * 0.99, ["time_step"]),
    ],
)
def test_median_time_step_just_inside_and_outside(step, found):
    n = 60
    log = _log(np.ones(n), np.ones(n), np.full((n, 3), np.nan), dt=step)
    assert _checks(log) == found


# ----------------------------------------------------------------- travel
def test_wheel_travel_is_the_centre_speed_even_when_the_tracks_turn_opposite_ways():
    """Tracks at -1 and +1.6 m/s: the centre moves 0.3 m/s, not the mean of the track speeds.

    The poses are exact (``position_noise`` tiny): the travel is compared over
    every interval, not over chords long against a GPS's noise.
    """
    n = _rows(40.0)
    log = _drive(np.full(n, -1.0), np.full(n, 1.6))
    result = check_log(log, TRACK, LIM, position_noise=1e-9)
    assert result.wheel_travel == pytest.approx(0.3 * 40.0, rel=1e-12)
    # the poses' chords of a tight arc are a little shorter than the arc: a ratio near 1
    assert 0.85 < result.pose_travel / result.wheel_travel < 1.0
    assert result.ok, result.findings


@pytest.mark.parametrize("side", [0, 1])
@pytest.mark.parametrize(("margin", "found"), [(0.98, []), (1.02, ["travel"])])
def test_travel_ratio_just_inside_and_outside(side, margin, found):
    """Poses moving straight at ``ratio`` times the wheels' 1 m/s, the ratio just beyond a bound."""
    bound = LIM.travel_ratio[side]
    ratio = bound / margin if side == 0 else bound * margin
    n = _rows(30.0)
    assert _checks(_drive(np.ones(n), np.ones(n), pose_speed=ratio)) == found


@pytest.mark.parametrize(("factor", "found"), [(0.95, []), (1.05, ["travel"])])
def test_travel_is_judged_only_over_min_travel(factor, found):
    """Poses travel x3 the wheels: judged only once both went ``min_travel``."""
    seconds = factor * LIM.min_travel  # wheels at 1 m/s
    n = _rows(seconds)
    assert _checks(_drive(np.ones(n), np.ones(n), pose_speed=3.0)) == found


@pytest.mark.parametrize(("hole", "found"), [(-1, ["travel"]), (0, ["travel"]), (1, [])])
def test_a_pose_gap_longer_than_max_interval_is_not_compared(hole, found):
    """The poses jump 60 m across a gap one row shorter than, as long as, longer than ``max_interval``.

    Compared, the jump is a travel finding (90 m of poses for 30 m of wheels);
    beyond ``max_interval`` the gap is not compared and the log is plausible.
    """
    n = _rows(30.0)
    v = np.ones(n)
    pose = integrate(v[:-1], np.zeros(n - 1), np.zeros(n - 1), np.full(n - 1, DT))
    k, after = 80, 80 + round(LIM.max_interval / DT) + hole  # last pose row before, first after
    rows = np.arange(n)
    measured = np.where(rows <= k, rows % PER == 0, (rows - after) % PER == 0) & (
        (rows <= k) | (rows >= after)
    )
    pose[~measured] = np.nan
    pose[after:, 0] += 60.0
    log = WheelLog(rows * DT, v, v, pose, None, np.zeros(n, int))
    assert (log.t[after] - log.t[k] <= LIM.max_interval) == bool(found)
    assert _checks(log) == found


# ------------------------------------------------------------ still checks
@pytest.mark.parametrize(("seconds", "found"), [(0.95, []), (1.0, ["still_wheels"])])
def test_still_wheels_needs_min_moving_time_of_pose_motion(seconds, found):
    """Poses move at 1 m/s while the wheels stand still, for a share of ``min_moving_time``."""
    n = _rows(seconds * LIM.min_moving_time)
    assert _checks(_drive(np.zeros(n), np.zeros(n), pose_speed=1.0)) == found


@pytest.mark.parametrize(("seconds", "found"), [(0.95, []), (1.0, ["still_poses"])])
def test_still_poses_needs_min_moving_time_of_wheel_motion(seconds, found):
    n = _rows(seconds * LIM.min_moving_time)
    assert _checks(_drive(np.ones(n), np.ones(n), pose_speed=0.0)) == found


@pytest.mark.parametrize(("still", "found"), [(31, []), (32, ["still_wheels"])])
def test_still_fraction_just_inside_and_outside(still, found):
    """40 intervals of poses moving at 1 m/s; the wheels stand still in ``still`` of them."""
    assert LIM.still_fraction == 32 / 40
    n = 40 * PER + 1
    v = np.full(n, 1.0)
    v[: still * PER] = 0.0
    log = _drive(v, v, pose_speed=1.0)
    assert [c for c in _checks(log) if c.startswith("still")] == found


@pytest.mark.parametrize("speed_share", [0.9, 1.1])
@pytest.mark.parametrize("creeping", ["poses", "wheels"])
def test_moving_speed_is_the_threshold_of_motion(creeping, speed_share):
    """One side creeps at just under / over ``moving_speed`` for 20 s, the other stands still."""
    n = _rows(20.0)
    speed = speed_share * LIM.moving_speed
    if creeping == "poses":
        log, check = _drive(np.zeros(n), np.zeros(n), pose_speed=speed), "still_wheels"
    else:
        log, check = _drive(np.full(n, speed), np.full(n, speed), pose_speed=0.0), "still_poses"
    assert _checks(log) == ([] if speed_share < 1 else [check])


# ---------------------------------------------------------------- heading
def _heading_log(corr: float, scale: float = 1.0, turn: float = 3.0, seed: int = 0) -> WheelLog:
    """Heading-only poses whose changes have correlation ``corr`` with the wheels' turn.

    The wheels turn ``w_i`` over interval ``i`` (total ``sum |w| = turn`` rad);
    the heading changes ``m = scale * (corr * w + sqrt(1 - corr**2) * u)`` with
    ``u`` orthogonal to ``w`` and as long, so the fitted scale is ``scale * corr``.
    """
    rng = np.random.default_rng(seed)
    w = rng.uniform(-1.0, 1.0, 60)
    w *= turn / np.sum(np.abs(w))
    u = rng.standard_normal(w.size)
    u -= (u @ w) / (w @ w) * w
    u *= np.linalg.norm(w) / np.linalg.norm(u)
    m = scale * (corr * w + np.sqrt(1.0 - corr**2) * u)
    half = np.repeat(w / 2.0, PER) / (PER * DT)  # (v_r - v_l) / 2 over each interval
    v_l, v_r = np.r_[1.0 - half, 1.0], np.r_[1.0 + half, 1.0]
    pose = np.full((v_l.size, 3), np.nan)
    pose[::PER, 2] = wrap_angle(np.r_[0.0, np.cumsum(m)])
    return _log(v_l, v_r, pose)


def test_the_heading_log_has_the_correlation_it_was_built_with():
    result = check_log(_heading_log(0.6, scale=0.8), TRACK, LIM)
    assert result.yaw_correlation == pytest.approx(0.6, abs=1e-9)
    assert result.yaw_scale == pytest.approx(0.48, abs=1e-9)


@pytest.mark.parametrize(
    ("corr", "found"),
    [
        (-0.99, ["yaw_sign"]),
        (-1.05, ["yaw_sign"]),
        (-0.95, ["yaw_follow"]),
        (0.95, ["yaw_follow"]),
        (1.05, []),
    ],
)
def test_correlation_thresholds_just_inside_and_outside(corr, found):
    """``corr`` in units of ``min_correlation`` (beyond -1 of them: the heading turns against the wheels)."""
    c = corr * LIM.min_correlation if abs(corr) != 0.99 else -0.99
    assert _checks(_heading_log(c, scale=1.0 / abs(c))) == found


@pytest.mark.parametrize(
    ("scale", "found"),
    [
        (0.98 * LIM.yaw_scale[0], ["yaw_follow"]),
        (1.02 * LIM.yaw_scale[0], []),
        (0.98 * LIM.yaw_scale[1], []),
        (1.02 * LIM.yaw_scale[1], ["yaw_follow"]),
    ],
)
def test_yaw_scale_just_inside_and_outside(scale, found):
    assert _checks(_heading_log(1.0, scale=scale, turn=30.0)) == found


@pytest.mark.parametrize(("share", "found"), [(0.95, []), (1.05, ["yaw_sign"])])
def test_yaw_checks_only_after_min_turn(share, found):
    """A heading turning against the wheels, judged only once both turned ``min_turn``."""
    assert _checks(_heading_log(-1.0, turn=share * LIM.min_turn)) == found


def test_a_log_without_poses_or_without_motion_is_not_judged():
    """The twin of the real-log test: nothing to compare is no finding, with NaN figures."""
    n = _rows(30.0)
    bare = _log(np.full(n, 5.0), np.full(n, -5.0), np.full((n, 3), np.nan))
    result = check_log(bare, TRACK, LIM)
    # no interval compared: 0 m (the docstring says NaN without positions; either is "none")
    assert result.ok and result.wheel_travel == 0.0 and not result.pose_travel > 0.0
    assert np.isnan(result.yaw_scale) and np.isnan(result.yaw_correlation)
    standing = _drive(np.zeros(n), np.zeros(n))
    result = check_log(standing, TRACK, LIM)
    assert result.ok and result.wheel_travel == 0.0 and result.pose_travel == 0.0


@pytest.mark.parametrize("side", [0, 1])
def test_a_travel_ratio_exactly_at_a_bound_is_plausible(side):
    n = _rows(30.0)
    ratio = LIM.travel_ratio[side]  # 0.5 and 2.0: exact in binary, as are the distances
    result = check_log(_drive(np.ones(n), np.ones(n), pose_speed=ratio), TRACK, LIM)
    assert result.pose_travel / result.wheel_travel == ratio
    assert result.ok, result.findings


def test_the_travel_finding_names_both_distances_and_the_likely_causes():
    n = _rows(30.0)
    (finding,) = check_log(_drive(np.ones(n), np.ones(n), pose_speed=3.0), TRACK, LIM).findings
    assert finding.check == "travel"
    assert finding.message == (
        "the poses travel 90.0 m where the wheels say 30.0 m (x3.00): check the wheel radius, "
        "and whether the speeds are rad/s (omega_*) or m/s (v_*)"
    )


def test_each_segment_is_compared_on_its_own_rows():
    """30 s at 1 m/s, then a segment restarting at the origin: 20 s at 0.5 m/s from t = 100 s."""
    n, m = _rows(30.0), _rows(20.0)
    one, two = _drive(np.ones(n), np.ones(n)), _drive(np.full(m, 0.5), np.full(m, 0.5))
    both = WheelLog(
        np.r_[one.t, 100.0 + two.t], np.r_[one.v_l, two.v_l], np.r_[one.v_r, two.v_r],
        np.r_[one.pose, two.pose], None, np.repeat([0, 1], [n, m]),
    )  # fmt: skip
    result = check_log(both, TRACK, LIM)
    assert result.ok, result.findings
    assert result.wheel_travel == result.pose_travel == 30.0 + 10.0


def test_the_wheels_turn_is_the_speed_difference_over_the_track_width():
    """The same log judged with a track width twice as wide: the wheels turn half as much."""
    log = _heading_log(0.6, scale=0.8)
    narrow, wide = (check_log(log, width, LIM) for width in (TRACK, 2.0 * TRACK))
    assert wide.yaw_scale == pytest.approx(2.0 * narrow.yaw_scale, rel=1e-12)
    assert wide.yaw_correlation == pytest.approx(narrow.yaw_correlation, rel=1e-12)


def test_an_empty_log_is_not_judged():
    empty = WheelLog(
        np.zeros(0), np.zeros(0), np.zeros(0), np.zeros((0, 3)), None, np.zeros(0, int)
    )
    result = check_log(empty, TRACK, LIM)
    assert result.ok and result.wheel_travel == 0.0 and np.isnan(result.median_step)


@pytest.mark.parametrize(
    ("wheels", "poses", "text"),
    [
        (0.0, 1.0, "the poses move while the wheels stand still over 100 % of 20 s of motion"),
        (1.0, 0.0, "the wheels turn while the poses stand still over 100 % of 20 s of motion"),
    ],
)
def test_the_still_findings_say_which_side_stands_still(wheels, poses, text):
    n = _rows(20.0)
    log = _drive(np.full(n, wheels), np.full(n, wheels), pose_speed=poses)
    (finding,) = check_log(log, TRACK, LIM).findings
    assert finding.message == f"{text}: wrong wheel columns, or poses of another run"

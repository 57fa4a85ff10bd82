"""Terrain-adaptive odometry sample by sample: the streaming API a robot runs live.

:class:`OnlineOdometry` takes timestamped samples as they arrive::

    odo = OnlineOdometry.from_config("config/warthog.yaml")
    odo.terrain(t, "grass")        # a terrain label (log, classifier, operator)
    odo.wheels(t, v_l, v_r)        # track surface speeds, m/s: predicts to t
    odo.pose(t, x, y, yaw)         # a pose measurement at t (yaw alone: heading only)
    odo.frame(t, image)            # a camera frame: ROI -> features -> vote -> tracker
    odo.state()                    # t, x, y, yaw, y_l, y_r, x_icr(, alpha), terrain, std_*

Wheel speeds given at ``t`` are held until the next :meth:`~OnlineOdometry.wheels`
call (zero-order hold), which predicts over the interval. A pose measurement
may hold any subset of ``x, y, yaw`` (a GPS fix, a heading, both), as the
sensors of ``config.pose_sensor`` measure them (antenna lever arm, heading
offset: :mod:`~terrain_odom.estimation.pose_measurement`); what became of each
component is counted in :attr:`OnlineOdometry.pose_use`. The ICR EKF anchors
the heading and the position of every segment at their first measurements
(the heading from the course of the fixes when none is measured) and never
propagates the pose across a segment break (``wheels(..., new_segment=True)``). Terrain labels pass through
a :class:`~terrain_odom.estimation.terrain.TerrainTracker`; a confirmed change
resets the ICR covariance to ``P_B`` (and restores a remembered estimate). With
``terrain.reset_at: arrival`` a change confirmed from frames is applied once the
robot has travelled (speed of the current kinematic model, integrated) to where
the first frame of the new terrain looked; pending changes are applied in order.

:func:`~terrain_odom.estimation.odometry.run_icr_ekf` and the command line's
``terrain-odom run`` are this API called row by row over a log.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, Protocol

import numpy as np

from terrain_odom.config import Config, load_config
from terrain_odom.errors import ConfigError, EstimationError
from terrain_odom.estimation.icr_ekf import HeadingBias, IcrEkf, IcrPriors
from terrain_odom.estimation.pose_measurement import (
    Mounting,
    PoseUse,
    robot_pose,
    sensor_pose,
)
from terrain_odom.estimation.terrain import TerrainTracker
from terrain_odom.kinematics import relative_pose, twist_icr, wrap_angle
from terrain_odom.records import Sighting, TerrainChange

if TYPE_CHECKING:  # the classifier's modules (scikit-learn) load only with a classifier
    from terrain_odom.estimation.slip_ekf import SlipEkf
    from terrain_odom.vision.classifier import TerrainClassifier
    from terrain_odom.vision.frame_classifier import FrameClassification, FrameClassifier

__all__ = ["ESTIMATORS", "Estimator", "OnlineOdometry"]

Estimator = Literal["icr-ekf", "slip-ekf"]
ESTIMATORS: tuple[Estimator, ...] = ("icr-ekf", "slip-ekf")
"""The estimators :class:`OnlineOdometry` runs."""


class OnlineOdometry:
    """Terrain-adaptive odometry fed one sample at a time.

    Parameters
    ----------
    config : Config
        Filter, terrain, camera and region-of-interest settings.
    classifier : TerrainClassifier, optional
        Terrain classifier for :meth:`frame`; without one, frames cannot be
        given (labels and sightings can).
    estimator : {"icr-ekf", "slip-ekf"}
        The ICR EKF over pose and ICRs, or the slip-parameter EKF, whose
        ``x, y, yaw`` are dead reckoning reset to every measured pose
        component and whose ``y_l, y_r, x_icr`` are the ICRs at the current
        track speeds, followed by the parameters ``l1 .. l6(, alpha)``.
    priors : IcrPriors, optional
        Offline ICR parameters seeding the ICR EKF (not for ``slip-ekf``).
    use_roi : bool
        Classify the region of interest (default) or the whole frame.
    time_full_frame : bool
        Also time the whole frame's classification (see
        :class:`~terrain_odom.vision.frame_classifier.FrameClassifier`).

    Attributes
    ----------
    n_updates : int
        Pose measurements that updated the filter.
    pose_use : PoseUse
        Position and heading components measured, used, and dropped by reason.

    Raises
    ------
    ConfigError
        Unknown estimator, priors with the slip EKF, or
        ``pose_sensor.heading_offset: auto`` (resolved from a whole log only).

    Examples
    --------
    >>> from terrain_odom.config import Config, load_config
    >>> odo = OnlineOdometry(Config())
    >>> odo.terrain(0.0, "grass")
    >>> odo.wheels(0.0, 0.5, 0.5)
    >>> odo.pose(0.0, 0.0, 0.0, 0.0)
    False
    >>> odo.wheels(1.0, 0.5, 0.5)
    >>> round(odo.state()["x"], 3), odo.state()["terrain"]
    (0.5, 'grass')
    """

    def __init__(
        self,
        config: Config,
        classifier: TerrainClassifier | None = None,
        *,
        estimator: Estimator = "icr-ekf",
        priors: IcrPriors | None = None,
        use_roi: bool = True,
        time_full_frame: bool = False,
    ) -> None:
        if estimator not in ESTIMATORS:
            raise ConfigError(f"unknown estimator {estimator!r}; choose one of {list(ESTIMATORS)}")
        mounting = _mounting(config)
        steps: _IcrSteps | _SlipSteps
        if estimator == "slip-ekf":
            from terrain_odom.estimation.slip_ekf import SlipEkf  # lazy: ICR runs skip its kernels

            if priors is not None or config.pose_sensor.heading_bias:
                raise ConfigError(
                    "priors seed the ICR EKF (estimator icr-ekf); the slip EKF's parameters "
                    "l1 .. l6 are not ICRs"
                    if priors is not None
                    else "pose_sensor.heading_bias is a state of the ICR EKF only: use "
                    "estimator icr-ekf, or set it false"
                )
            ekf = SlipEkf(config.slip_ekf, config.robot.track_width, config.terrain)
            steps = _SlipSteps(ekf, mounting)
        else:
            icr_ekf = IcrEkf(
                config.ekf,
                config.terrain,
                priors=priors,
                mounting=mounting,
                robot=config.robot,
                heading_bias=HeadingBias.from_config(config.pose_sensor),
            )
            steps = _IcrSteps(icr_ekf)
        self.config = config
        self.estimator = estimator
        self._steps = steps
        self._flow = _TerrainFlow(steps.filter, config)
        self._frames: FrameClassifier | None = None
        if classifier is not None:
            from terrain_odom.vision.camera import GroundCamera
            from terrain_odom.vision.frame_classifier import FrameClassifier

            self._frames = FrameClassifier(
                classifier,
                GroundCamera(config.camera),
                config.roi,
                use_roi=use_roi,
                time_full_frame=time_full_frame,
            )
        self._t: float | None = None  # time of the latest wheel sample, s
        self._speeds = (float("nan"), float("nan"))  # held track speeds, m/s
        self._labels: list[tuple[float, str]] = []  # labels not yet reached, by time
        self._label: Sighting | None = None  # the label source's current label
        self.n_updates = 0
        self.n_frames = 0
        self.pose_use = PoseUse()

    @classmethod
    def from_config(
        cls, path: str | Path | None, classifier: TerrainClassifier | None = None, **options: Any
    ) -> OnlineOdometry:
        """Build from a YAML configuration file (the built-in defaults for ``None``).

        ``options`` are the keyword arguments of :class:`OnlineOdometry`.
        """
        return cls(load_config(path), classifier, **options)

    # --------------------------------------------------------------- inputs
    def terrain(self, t: float, label: str) -> None:
        """Take a terrain label valid from time ``t`` (s) on, from any source.

        The label is observed by the terrain tracker at every later
        :meth:`wheels` call whose time is ``>= t`` (after its prediction),
        until another label replaces it; a change is confirmed after
        ``terrain.confirm`` consecutive observations.
        """
        t = _finite(t, "terrain", "t")
        bisect.insort(self._labels, (t, str(label)), key=lambda item: item[0])

    def wheels(self, t: float, v_l: float, v_r: float, *, new_segment: bool = False) -> None:
        """Take the track surface speeds measured at ``t``; predict to ``t``.

        The previous speeds are held from the previous call to ``t``; the new
        ones are held until the next call. Then the terrain changes whose
        ground the robot has reached are applied and the current terrain
        label (see :meth:`terrain`) is observed.

        Parameters
        ----------
        t : float
            Time, s; after the previous call's, unless ``new_segment``.
        v_l, v_r : float
            Left and right track surface speeds, m/s.
        new_segment : bool
            Start a new segment at ``t`` (time may jump, or restart): nothing
            is integrated across the break and the pose is anchored again at
            the next full pose measurement. The first call always starts one.

        Raises
        ------
        ValueError
            A value is not finite.
        EstimationError
            ``t`` is not after the previous wheel sample within a segment.
        """
        t = _finite(t, "wheels", "t")
        speeds = (_finite(v_l, "wheels", "v_l", t), _finite(v_r, "wheels", "v_r", t))
        steps = self._steps
        if self._t is None or new_segment:
            steps.restart(t)
        else:
            if not t > self._t:
                raise EstimationError(
                    f"wheels at t={t!r} s: time does not advance (previous wheel sample at "
                    f"t={self._t!r} s); pass new_segment=True to start a new segment"
                )
            dt = t - self._t
            held_l, held_r = self._speeds
            if self._flow.odometer_on:  # odometer over the step about to be predicted
                v_x, v_y, _ = twist_icr(held_l, held_r, *steps.icr_params(held_l, held_r))
                self._flow.travel(float(np.hypot(v_x, v_y)) * dt)
            steps.predict(held_l, held_r, dt)
        self._t, self._speeds = t, speeds
        steps.sample(t, *speeds)
        self._flow.apply_reached()
        if self._labels and self._labels[0][0] <= t:  # a label reached: the rare case
            reached = bisect.bisect_right(self._labels, t, key=lambda item: item[0])
            self._label = Sighting(self._labels[reached - 1][1])
            del self._labels[:reached]
        if self._label is not None:
            self._flow.observe(self._label)

    def pose(self, t: float, x: float = np.nan, y: float = np.nan, yaw: float = np.nan) -> bool:
        """Fuse a pose measurement taken at the latest wheel sample's time ``t``.

        Parameters
        ----------
        t : float
            Time, s: that of the latest :meth:`wheels` call (give the latest
            speeds again at a pose's time if it falls between wheel samples).
        x, y, yaw : float
            Measured pose (m, m, rad); NaN where not measured (e.g. ``yaw``
            alone: heading only).

        Returns
        -------
        bool
            Whether the filter was updated (False when the measurement only
            anchored the pose, was the first of its kind in the slip EKF, or
            was dropped: see :attr:`pose_use`).

        Raises
        ------
        ValueError
            No component is given.
        EstimationError
            ``t`` is not the latest wheel sample's time.
        """
        z = np.array([x, y, yaw], dtype=float)
        finite = [math.isfinite(c) for c in z.tolist()]  # floats: cheaper than numpy per row
        if not any(finite):
            raise ValueError(f"pose at t={t!r} s: no finite component in x={x}, y={y}, yaw={yaw}")
        if self._check_time(t, "pose") != self._t:
            raise EstimationError(
                f"pose at t={t!r} s: the filter is at t={self._t!r} s (the latest wheel "
                "sample); call wheels(t, v_l, v_r) at the pose's time first"
            )
        rows = _measured_rows(finite)
        self.pose_use.measured(rows, z)
        updated = self._steps.measure(z, rows, self.pose_use)
        self.n_updates += updated
        return updated

    def rows(
        self,
        t: np.ndarray,
        v_l: np.ndarray,
        v_r: np.ndarray,
        pose: np.ndarray,
        *,
        new_segment: bool = False,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Take a stretch of log rows: per row :meth:`wheels`, :meth:`pose`, :meth:`estimate`.

        Equal, bit for bit, to calling :meth:`wheels` for each row (the
        first with ``new_segment``), :meth:`pose` for each row with a finite
        component, and :meth:`estimate` after it. Labels, sightings and
        frames go between stretches. Once the ICR EKF has anchored the pose
        and the terrain is steady (no change being confirmed or pending),
        the rest of the stretch runs in one compiled call
        (:meth:`~terrain_odom.estimation.icr_ekf.IcrEkf.run_rows`), ~10x
        faster than the calls one by one.

        Parameters
        ----------
        t : ndarray, shape (B,)
            Times, s, increasing, after the latest wheel sample.
        v_l, v_r : ndarray, shape (B,)
            Track surface speeds, m/s.
        pose : ndarray, shape (B, 3)
            Measured ``x, y, yaw`` (m, m, rad), NaN where not measured.
        new_segment : bool
            The first row starts a new segment (see :meth:`wheels`).

        Returns
        -------
        states, stds : ndarray, shape (B, n)
            :meth:`estimate` after each row.
        terrain : ndarray of object, shape (B,)
            :attr:`current_terrain` after each row.

        Raises
        ------
        ValueError, EstimationError
            As :meth:`wheels` and :meth:`pose`, at the first row at fault.
        """
        n_rows, n = len(t), len(self.names)
        states, stds = np.empty((n_rows, n)), np.empty((n_rows, n))
        terrain = np.empty(n_rows, dtype=object)
        valid = _valid_from(t, v_l, v_r)
        k = 0
        while k < n_rows and (
            (new_segment and k == 0) or not (self._steady() and valid[k] and t[k] > self._t)
        ):
            self.wheels(
                float(t[k]), float(v_l[k]), float(v_r[k]), new_segment=new_segment and k == 0
            )
            if np.isfinite(pose[k]).any():
                self.pose(float(t[k]), *pose[k].tolist())
            states[k], stds[k] = self.estimate()
            terrain[k] = self.current_terrain
            k += 1
        terrain[k:] = self.current_terrain
        if k < n_rows:
            assert isinstance(self._steps, _IcrSteps) and self._t is not None  # _steady()
            ekf = self._steps.filter
            counted = ekf.gating[4:].copy()
            states[k:], stds[k:], updates = ekf.run_rows(
                (self._t, *self._speeds), t[k:], (v_l[k:], v_r[k:]), pose[k:]
            )
            self.n_updates += updates
            self.pose_use.fused(pose[k:])
            self.pose_use.gated(ekf.gating[4:] - counted)
            self._t, self._speeds = float(t[-1]), (float(v_l[-1]), float(v_r[-1]))
        return states, stds, terrain

    def _steady(self) -> bool:
        """Whether rows can run in one call: the ICR EKF anchored, the terrain steady."""
        steps = self._steps
        return (
            isinstance(steps, _IcrSteps)
            and steps.anchored
            and self._t is not None
            and not self._labels
            and self._flow.steady(self._label)
        )

    def frame(self, t: float, image: np.ndarray) -> FrameClassification:
        """Classify a camera frame and feed its label to the terrain tracker.

        The region of interest follows from the held wheel speeds and the
        current ICR estimate.

        Parameters
        ----------
        t : float
            Frame time, s (not before the latest wheel sample).
        image : ndarray, shape (height, width, 3)
            The frame, RGB, uint8.

        Returns
        -------
        FrameClassification
            Label (``""`` if the region was unusable), distance ahead, timings.

        Raises
        ------
        ConfigError
            No classifier was given, or the image is not the camera's size.
        EstimationError
            Before any wheel sample, or ``t`` before the latest one.
        """
        if self._frames is None:
            raise ConfigError("frame() needs a terrain classifier: OnlineOdometry(config, clf)")
        t = self._check_time(t, "frame")
        v_l, v_r = self._speeds
        params = self._steps.icr_params(v_l, v_r)
        whole_first = self.n_frames % 2 == 0
        result = self._frames.classify(t, image, v_l, v_r, params, whole_first=whole_first)
        self.n_frames += 1
        if result.sighting is not None:
            self._flow.observe(result.sighting)
        return result

    def sighting(self, t: float, sighting: Sighting) -> None:
        """Feed a terrain seen ahead at ``t`` (s), e.g. a frame classified elsewhere."""
        self._check_time(t, "sighting")
        self._flow.observe(sighting)

    def _check_time(self, t: float, what: str) -> float:
        """Return ``t`` as a float if a wheel sample at or before it was given."""
        t = _finite(t, what, "t")
        if self._t is None:
            raise EstimationError(f"{what} at t={t!r} s: no wheel speeds yet, call wheels() first")
        if t < self._t:
            raise EstimationError(
                f"{what} at t={t!r} s: time goes backwards (latest wheel sample at t={self._t!r} s)"
            )
        return t

    # --------------------------------------------------------------- output
    @property
    def names(self) -> tuple[str, ...]:
        """Names of the estimated values, in the order of :meth:`estimate`."""
        return self._steps.names

    @property
    def t(self) -> float | None:
        """Time of the latest wheel sample, s (None before the first)."""
        return self._t

    @property
    def current_terrain(self) -> str:
        """Terrain applied to the filter (``""`` before any label)."""
        return self._steps.filter.terrain or ""

    @property
    def seen_terrain(self) -> str:
        """Terrain confirmed by the observations so far (ahead of the robot for a camera)."""
        return self._flow.seen or ""

    @property
    def odometer(self) -> float:
        """Distance the terrain changes are placed by, m (counting from the first sighting ahead).

        A sighting made at odometer value ``d0`` and fed later at ``d1``
        (a frame classified off the wheel path) is placed where it was seen
        with ``ahead - (d1 - d0)``.
        """
        return self._flow.travelled

    @property
    def changes(self) -> list[TerrainChange]:
        """Terrain changes applied so far."""
        return self._flow.changes

    def estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the estimate and its standard deviation, in :attr:`names` order."""
        return self._steps.estimate(*self._speeds)

    def state(self) -> dict[str, float | str | None]:
        """Return the current estimate as a mapping.

        Keys: ``t`` (s), the :attr:`names` (``x, y, yaw, y_l, y_r, x_icr``
        and ``alpha`` if estimated, or the slip parameters), ``terrain``
        (applied, ``""`` before any label) and ``std_<name>`` for each name.
        """
        state, std = self.estimate()
        out: dict[str, float | str | None] = {"t": self._t}
        out.update(zip(self.names, state.tolist(), strict=True))
        out["terrain"] = self.current_terrain
        out.update((f"std_{n}", s) for n, s in zip(self.names, std.tolist(), strict=True))
        return out


def _mounting(config: Config) -> Mounting:
    """Return the pose sensors' mounting of ``config`` (``pose_sensor``) as numbers."""
    sensor = config.pose_sensor
    values = {k: getattr(sensor, k) for k in ("antenna_x", "antenna_y", "heading_offset")}
    auto = [k for k, v in values.items() if v == "auto"]
    if auto:
        raise ConfigError(
            f"pose_sensor.{', '.join(auto)}: auto is estimated from a whole log (terrain-odom "
            "run or calibrate, app.calibration.calibrate_config); give OnlineOdometry numbers"
        )
    return Mounting(*(float(v) for v in values.values()))


def _valid_from(t: np.ndarray, v_l: np.ndarray, v_r: np.ndarray) -> np.ndarray:
    """Per row ``k``: whether rows ``k:`` are finite and advance in time after row ``k``.

    Where not, :meth:`OnlineOdometry.wheels` run row by row says why.
    """
    ok = np.isfinite(t) & np.isfinite(v_l) & np.isfinite(v_r)
    ok[1:] &= t[1:] > t[:-1]
    return np.logical_and.accumulate(ok[::-1])[::-1]


def _measured_rows(finite: list[bool]) -> tuple[int, ...]:
    """Return the measured components (indices into ``x, y, yaw``) given which are finite.

    The rule of :func:`~terrain_odom.estimation.pose_measurement.measured_rows`
    (a position only as a pair), on Python booleans: a pose row costs less.
    """
    pair = (0, 1) if finite[0] and finite[1] else ()
    return (*pair, _YAW) if finite[_YAW] else pair


def _finite(value: float, what: str, name: str, t: float | None = None) -> float:
    """Return ``value`` as a float, or raise naming it if it is not finite."""
    number = float(value)
    if not math.isfinite(number):
        at = "" if t is None else f" t={t!r} s:"
        raise ValueError(f"{what} at{at} {name}={value!r} is not finite")
    return number


class _RowFilter(Protocol):
    """The part of a filter the terrain flow uses."""

    t: float
    terrain: str | None

    def set_terrain(self, label: str) -> None:
        """Name the terrain the filter starts on, without any reset."""
        ...  # pragma: no cover

    def reset_on_terrain_change(self, label: str) -> TerrainChange:
        """Apply a confirmed change to terrain ``label``."""
        ...  # pragma: no cover


_YAW = 2
_POSITION, _HEADING = "position", "heading"
_HEADING_AGE = 1.0  # s: the slip EKF's dead-reckoned heading older than this orients no position
_CLOSE_FIX = "no heading, and within a quarter chord of the previous fix (standing)"


class _IcrSteps:
    """The ICR EKF: predict every wheel sample, anchor then update at poses.

    Each segment anchors the heading at its first measured heading and the
    position at its first position once the heading is known. Without a
    measured heading (a GPS alone), the heading is taken from the course:
    the first fix anchors the position in a provisional frame, the fixes
    after it keep the position within two ``sigma_r`` of them (no dead
    reckoning far on a heading not yet known), and once a fix lies
    ``min_course`` m from the first the frame
    is turned so that the filter's dead-reckoned antenna displacement
    points along the measured one. Only then do fixes update the filter.
    """

    def __init__(self, ekf: IcrEkf) -> None:
        self.filter = ekf
        self.names = ekf.names
        sig = ekf.config.sigma_r
        self._r = np.array([sig.x, sig.y, sig.yaw])
        self._min_course = max(1.0, 10.0 * max(sig.x, sig.y))
        self.restart(0.0)

    def restart(self, t: float) -> None:
        self._heading = self._position = False  # a break: nothing is integrated across it
        self._course: tuple[np.ndarray, np.ndarray] | None = None  # first fix, its prediction
        self.filter.t = t

    @property
    def anchored(self) -> bool:
        """Whether heading and position are anchored: every pose component is fused."""
        return self._heading and self._position

    def predict(self, v_l: float, v_r: float, dt: float) -> None:
        self.filter.predict(v_l, v_r, dt)

    def sample(self, t: float, v_l: float, v_r: float) -> None:
        """Nothing to keep: the ICR EKF predicts sample by sample."""

    def measure(self, z: np.ndarray, rows: tuple[int, ...], use: PoseUse) -> bool:
        position, heading = 0 in rows, _YAW in rows  # components left to fuse
        if heading and not self._heading:
            self._anchor(z, heading=True)
            heading = False
            use.used(_HEADING)
        if position and not self._position:
            position = False
            if self._heading:
                self._anchor(z, heading=False)
                use.used(_POSITION)
            else:
                self._course_heading(z)
                use.used(_POSITION)
        if not (position or heading):
            return False
        nan = math.nan
        x, y, yaw = z.tolist()
        counted = self.filter.gating[4:].copy()
        nis = self.filter.update(np.array([x if position else nan, y if position else nan,
                                           yaw if heading else nan]))  # fmt: skip
        if position:
            use.used(_POSITION)
        if heading:
            use.used(_HEADING)
        use.gated(self.filter.gating[4:] - counted)
        return not math.isnan(nis)

    def _anchor(self, z: np.ndarray, *, heading: bool) -> None:
        """Reset the heading (``heading``) or the position to the measured one."""
        ekf = self.filter
        if heading:
            ekf.anchor_heading(z[_YAW], self._r[_YAW])
            self._heading = True
            self._course = None  # a provisional frame of the course is no longer needed
            return
        pose, sigma = ekf.pose, ekf.std[:3]
        pose[:2] = robot_pose(z, ekf.mounting, yaw=pose[_YAW])[:2]
        sigma[:2] = self._r[:2]
        self._position = True
        ekf.reset_pose(pose, sigma)

    def _course_heading(self, z: np.ndarray) -> None:
        """Take the heading from the course between fixes (no heading measured yet).

        The first fix anchors the position in a provisional frame (the
        heading as it was); until a fix lies ``min_course`` m from the
        first, whose chord turns the frame, a fix more than two ``sigma_r``
        from the dead-reckoned position resets it to the fix.
        """
        ekf = self.filter
        predicted = sensor_pose(ekf.pose, ekf.mounting)[:2]
        if self._course is None:
            ekf.reset_pose(robot_pose(z, ekf.mounting, yaw=ekf.pose[_YAW]), ekf.std[:3])
            self._course = (z[:2].copy(), sensor_pose(ekf.pose, ekf.mounting)[:2])
            return
        measured = z[:2] - self._course[0]
        moved = predicted - self._course[1]
        distance = float(np.hypot(*measured))
        if distance < self._min_course or not np.hypot(*moved) > 0.5 * distance:
            # Not far enough yet. Dead reckoning on the provisional heading would draw an
            # excursion: the position is held to the fix once two sigma_r off it, the frame's
            # origin moved with it (the dead-reckoned chord is kept).
            if np.hypot(*(predicted - z[:2])) > 2.0 * max(self._r[:2]):
                ekf.reset_pose(robot_pose(z, ekf.mounting, yaw=ekf.pose[_YAW]), ekf.std[:3])
                self._course = (self._course[0], self._course[1] - predicted + z[:2])
            return
        turn = np.arctan2(measured[1], measured[0]) - np.arctan2(moved[1], moved[0])
        yaw = float(wrap_angle(ekf.pose[_YAW] + turn))
        sigma = ekf.std[:3]
        sigma[:2] = self._r[:2]
        sigma[_YAW] = np.hypot(2.0 * max(self._r[:2]) / distance, 0.1)  # fix noise, path shape
        ekf.reset_pose(robot_pose(z, ekf.mounting, yaw=yaw), sigma)
        self._heading = self._position = True

    def icr_params(self, v_l: float, v_r: float) -> np.ndarray:
        return self.filter.params

    def estimate(self, v_l: float, v_r: float) -> tuple[np.ndarray, np.ndarray]:
        return self.filter.x, self.filter.std


class _Anchor(NamedTuple):
    """A measured pose a later pose change is measured from."""

    t: float
    pose: np.ndarray  # robot pose, unmeasured components dead-reckoned
    sample: int  # number of its wheel sample in the segment


class _CourseFixes:
    """Fixes without a heading, for the slip EKF: two chords of at least ``length`` m.

    A GPS alone fixes the path up to a rotation: from the fixes ``b, a, k``
    it measures the length of the chord ``a -> k`` and its turn from the
    chord ``b -> a`` (:func:`~terrain_odom.estimation.pose_measurement.chord_turn`),
    ``a`` the latest fix at least ``length`` m from ``k``, ``b`` the latest
    at least ``length`` m from ``a``. A fix within a quarter chord of the
    previous one kept is not kept (a standing robot keeps the buffer short).
    """

    def __init__(self, length: float, sigma: float) -> None:
        self.length = length
        self.sigma = sigma  # noise of a position change, m
        self.fixes: deque[tuple[np.ndarray, int]] = deque()  # (antenna x, y; wheel sample)

    def clear(self) -> None:
        self.fixes.clear()

    def add(
        self, xy: np.ndarray, sample: int
    ) -> tuple[bool, tuple[tuple[np.ndarray, int], tuple[np.ndarray, int]] | None]:
        """Keep a fix (unless too close); return whether kept, and the fixes ``b, a`` if any."""
        fixes = self.fixes
        if fixes and np.hypot(*(xy - fixes[-1][0])) < 0.25 * self.length:
            return False, None
        a = self._latest_away(xy, len(fixes))
        b = None if a is None else self._latest_away(fixes[a][0], a)
        pair = None if a is None or b is None else (fixes[b], fixes[a])
        for _ in range(b or 0):
            fixes.popleft()  # never an anchor again (unless the robot comes back)
        fixes.append((xy.copy(), sample))
        return True, pair

    def _latest_away(self, xy: np.ndarray, before: int) -> int | None:
        """Return the index of the latest fix before ``before`` at least a chord from ``xy``."""
        for k in range(before - 1, -1, -1):
            if np.hypot(*(xy - self.fixes[k][0])) >= self.length:
                return k
        return None

    def measured(
        self, xy_b: np.ndarray, xy_a: np.ndarray, xy_k: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Return the measured ``(length of a -> k, turn from b -> a)`` and their variances."""
        first, second = xy_a - xy_b, xy_k - xy_a
        l1, l2 = np.hypot(*first), np.hypot(*second)
        turn = wrap_angle(np.arctan2(second[1], second[0]) - np.arctan2(first[1], first[0]))
        return np.array([l2, turn]), self.sigma**2 * np.array([1.0, 1.0 / l1**2 + 1.0 / l2**2])


class _SlipSteps:
    """The slip EKF: a windowed pose change at every measured pose component.

    The measured components are turned into the robot's (heading offset,
    antenna lever arm at the measured or else dead-reckoned heading). A
    heading updates with the heading change since its anchor: the latest
    earlier heading of the same segment at least ``slip_ekf.window``
    seconds before (0: the previous one), or the segment's first one while
    the segment is shorter; a position likewise with the position change
    since its anchor among the positions, in the frame of the robot there
    (its heading measured, or dead-reckoned from one measured at most 1 s
    before). Where both anchors are one row, the whole pose change is one
    update. A position with no heading that recent (a GPS alone; the
    heading is no state of the slip EKF, and dead reckoning drifts) updates
    with what positions alone measure: a chord's length and its turn from
    the chord before (:class:`_CourseFixes`). The wheel
    samples since the oldest anchor still needed are kept (a bounded
    buffer: the window plus the gap between measurements). The reported
    pose (``x, y, yaw``) is dead reckoning with the current parameters from
    the origin at each segment start, reset to every measured pose component.
    """

    def __init__(self, ekf: SlipEkf, mounting: Mounting) -> None:
        from terrain_odom.estimation.slip_ekf import OUTPUT_NAMES

        self.filter = ekf
        self.names = OUTPUT_NAMES + ekf.names
        self.mounting = mounting
        self._window = ekf.config.window
        self._anchors: dict[str, deque[_Anchor]] = {_POSITION: deque(), _HEADING: deque()}
        self._samples: deque[tuple[float, float, float]] = deque()  # (t, v_l, v_r)
        sigma = ekf.config.sigma_r.dx
        self._course = _CourseFixes(max(0.5, 10.0 * sigma), sigma)
        self.restart(0.0)

    def restart(self, t: float) -> None:
        for chain in self._anchors.values():
            chain.clear()
        self._course.clear()
        self._samples.clear()
        self._first = 0  # number of self._samples[0] in the segment
        self._pose = np.zeros(3)
        self._headed = -np.inf  # time of the segment's latest measured heading, s
        self.filter.t = t

    def predict(self, v_l: float, v_r: float, dt: float) -> None:
        self.filter.predict(dt)
        self.filter.dead_reckon(self._pose, v_l, v_r, dt)

    def sample(self, t: float, v_l: float, v_r: float) -> None:
        self._samples.append((t, v_l, v_r))
        self._drop_samples(self._oldest_needed())

    def _oldest_needed(self) -> int:
        """Return the number of the oldest wheel sample an anchor still needs (else the newest)."""
        firsts = [chain[0].sample for chain in self._anchors.values() if chain]
        if self._course.fixes:
            firsts.append(self._course.fixes[0][1])
        return min(firsts, default=self._first + len(self._samples) - 1)

    def _drop_samples(self, first: int) -> None:
        """Forget the wheel samples before sample number ``first``."""
        while self._first < first:
            self._samples.popleft()
            self._first += 1

    def measure(self, z: np.ndarray, rows: tuple[int, ...], use: PoseUse) -> bool:
        has_position, has_heading = 0 in rows, _YAW in rows
        t = self._samples[-1][0]
        if has_heading:
            self._pose[_YAW] = wrap_angle(z[_YAW] - self.mounting.heading_offset)
            self._headed = t
        if has_position:
            self._pose[:2] = robot_pose(z, self.mounting, yaw=self._pose[_YAW])[:2]
        sample = self._first + len(self._samples) - 1
        course = has_position and t - self._headed > _HEADING_AGE
        updated = course and self._course_update(z[:2], sample, use)
        here = _Anchor(t, self._pose.copy(), sample)
        froms = {
            what: self._anchor(what, here)
            for what, measured in (
                (_POSITION, has_position and not course),
                (_HEADING, has_heading),
            )
            if measured
        }
        for what in froms:
            use.used(what)
        self._drop_samples(self._oldest_needed())
        changes = self._changes(froms)
        for anchor, mask in changes:
            self._update(anchor, here, mask)
        return bool(changes) or updated

    def _course_update(self, xy: np.ndarray, sample: int, use: PoseUse) -> bool:
        """Fuse a fix without a heading as the end of two chords (see :class:`_CourseFixes`)."""
        kept, pair = self._course.add(xy, sample)
        if not kept:
            use.drop(_POSITION, _CLOSE_FIX)
            return False
        use.used(_POSITION)
        if pair is None:
            return False
        (xy_b, b), (xy_a, a) = pair
        z, variances = self._course.measured(xy_b, xy_a, xy)
        samples = np.array(self._samples)
        first, second = (
            samples[start - self._first : end - self._first + 1].T
            for start, end in ((b, a), (a, sample))
        )
        self.filter.update_course(
            z,
            (first[1][:-1], first[2][:-1], np.diff(first[0])),
            (second[1][:-1], second[2][:-1], np.diff(second[0])),
            self.mounting.antenna,
            variances,
        )
        return True

    def _anchor(self, what: str, here: _Anchor) -> _Anchor | None:
        """Return the anchor of a ``what`` measured ``here`` (None: the first); chain ``here``."""
        chain = self._anchors[what]
        while len(chain) > 1 and chain[1].t <= here.t - self._window:
            chain.popleft()  # never needed again
        anchor = chain[0] if chain else None
        chain.append(here)
        return anchor

    @staticmethod
    def _changes(froms: dict[str, _Anchor | None]) -> list[tuple[_Anchor, np.ndarray]]:
        """Return the pose changes to fuse, ``(anchor, components)``: one where anchors agree."""
        position, heading = froms.get(_POSITION), froms.get(_HEADING)
        if position is not None and heading is not None and position.sample == heading.sample:
            return [(position, np.ones(3, dtype=bool))]
        out = []
        if position is not None:
            out.append((position, np.array([True, True, False])))
        if heading is not None:
            out.append((heading, np.array([False, False, True])))
        return out

    def _update(self, anchor: _Anchor, here: _Anchor, mask: np.ndarray) -> None:
        """Fuse the change of the ``mask`` components from ``anchor`` to ``here``."""
        samples = np.array(self._samples)
        t, v_l, v_r = samples[anchor.sample - self._first : here.sample - self._first + 1].T
        change = np.where(mask, relative_pose(anchor.pose, here.pose), np.nan)
        self.filter.update(change, v_l[:-1], v_r[:-1], np.diff(t))

    def icr_params(self, v_l: float, v_r: float) -> np.ndarray:
        icr = self.filter.icrs(v_l, v_r)
        alpha = self.filter.x[6] if len(self.filter.names) > 6 else 1.0
        return np.array([*map(float, icr), alpha])

    def estimate(self, v_l: float, v_r: float) -> tuple[np.ndarray, np.ndarray]:
        return self.filter.estimate(self._pose, v_l, v_r)


class _TerrainFlow:
    """Terrain labels into filter resets: confirmation, scheduling, odometer.

    ``seen`` is the terrain confirmed by the observations (ahead of the
    robot for a camera); ``ekf.terrain`` the one applied to the filter.
    """

    def __init__(self, ekf: _RowFilter, config: Config) -> None:
        self.ekf = ekf
        self.adapt = config.terrain.adapt
        self.on_arrival = config.terrain.reset_at == "arrival"
        self.tracker = TerrainTracker(config.terrain.confirm)
        self.travelled = 0.0  # m, odometer of the model's predicted motion
        # The odometer only places ground seen ahead: it runs from the first sighting
        # with ahead > 0 (arrival mode). Before, every target is the odometer's value at
        # the sighting, reached at once whether it counted or not.
        self.odometer_on = False
        self.pending: deque[tuple[float, str, float]] = deque()  # (odometer target, label, t)
        self.changes: list[TerrainChange] = []

    @property
    def seen(self) -> str | None:
        """Terrain confirmed by the observations so far."""
        return self.tracker.current

    def steady(self, label: Sighting | None) -> bool:
        """Whether observing ``label`` (None: no label) at every row would change nothing."""
        if self.odometer_on or self.pending:
            return False
        return label is None or (self.ekf.terrain is not None and self.tracker.steady(label.label))

    def travel(self, distance: float) -> None:
        """Advance the odometer by ``distance`` m."""
        self.travelled += distance

    def apply_reached(self) -> None:
        """Apply the pending changes whose ground the robot has reached."""
        while self.pending and self.travelled >= self.pending[0][0]:
            _, label, t_confirmed = self.pending.popleft()
            self._apply(label, t_confirmed)

    def observe(self, sighting: Sighting) -> None:
        """Feed one label; name the first terrain, apply or schedule a confirmed change."""
        where = self.travelled + (sighting.ahead if self.on_arrival else 0.0)
        self.odometer_on = self.odometer_on or where > self.travelled
        confirmed = self.tracker.observe(sighting.label, at=where)
        if self.ekf.terrain is None:
            self.ekf.set_terrain(self.tracker.current or sighting.label)
            return
        if confirmed is None:
            return
        target = self.tracker.changed_at
        if target is not None and target > self.travelled:
            self.pending.append((target, confirmed, self.ekf.t))
        elif not self.pending:
            self._apply(confirmed, None)
        else:  # reached already, but earlier changes are still pending: keep the order
            self.pending.append((self.travelled, confirmed, self.ekf.t))

    def _apply(self, label: str, t_confirmed: float | None) -> None:
        ekf = self.ekf
        if label == ekf.terrain:
            return
        if self.adapt:
            change = ekf.reset_on_terrain_change(label)
        else:
            change = TerrainChange(ekf.t, ekf.terrain, label, restored=False, reset=False)
            ekf.set_terrain(label)
        if t_confirmed is not None and t_confirmed < change.t:
            change = replace(change, t_confirmed=t_confirmed)
        self.changes.append(change)

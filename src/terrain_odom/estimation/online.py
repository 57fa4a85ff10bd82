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
offset: :mod:`~terrain_odom.kinematics.mounting`); what became of each
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

The parts: each estimator's steps behind
:class:`~terrain_odom.estimation.steps.FilterSteps`
(:class:`~terrain_odom.estimation.icr_steps.IcrSteps`,
:class:`~terrain_odom.estimation.slip_steps.SlipSteps`), the labels into
resets by :class:`~terrain_odom.estimation.terrain.TerrainFlow`.
"""

from __future__ import annotations

import bisect
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from terrain_odom.config import Config, load_config
from terrain_odom.errors import ConfigError, EstimationError
from terrain_odom.estimation.icr_ekf import IcrEkf, IcrPriors
from terrain_odom.estimation.icr_model import HeadingBias
from terrain_odom.estimation.icr_steps import IcrSteps
from terrain_odom.estimation.pose_measurement import PoseUse
from terrain_odom.estimation.steps import YAW, FilterSteps
from terrain_odom.estimation.terrain import TerrainFlow, model_speed
from terrain_odom.kinematics.mounting import Mounting
from terrain_odom.records import Sighting

if TYPE_CHECKING:  # the classifier's modules (scikit-learn) load only with a classifier
    from terrain_odom.records import TerrainChange
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
        steps = _filter_steps(config, estimator, priors)
        self.config = config
        self.estimator = estimator
        self._steps = steps
        self._flow = TerrainFlow(steps.filter, config)
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
                speed = model_speed(held_l, held_r, steps.icr_params(held_l, held_r))
                self._flow.travel(float(speed) * dt)
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
        faster than the calls one by one; the arrival odometer, once on, is
        advanced over those rows from their states (the same sums).

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
            self._batch(t[k:], (v_l[k:], v_r[k:]), pose[k:], states[k:], stds[k:])
        return states, stds, terrain

    def _batch(
        self,
        t: np.ndarray,
        speeds: tuple[np.ndarray, np.ndarray],
        pose: np.ndarray,
        states: np.ndarray,
        stds: np.ndarray,
    ) -> None:
        """Run rows in one call (the terrain steady), the odometer advanced over them.

        Writes the estimate and its standard deviation after each row into
        ``states`` and ``stds``.
        """
        batch = self._steps.batch()
        assert batch is not None and self._t is not None  # _steady()
        held = self._speeds
        before = self._steps.icr_params(*held)
        states[:], stds[:], params, updates = batch(
            (self._t, *held), t, speeds, pose, self.pose_use
        )
        self.n_updates += updates
        # Step i predicts with row i-1's speeds held and the model after row i-1.
        if self._flow.odometer_on:
            self._flow.travel_rows(
                t - _after(self._t, t),
                (_after(held[0], speeds[0]), _after(held[1], speeds[1])),
                np.vstack([before, params[:-1]]),
            )
        self._t, self._speeds = float(t[-1]), (float(speeds[0][-1]), float(speeds[1][-1]))

    def _steady(self) -> bool:
        """Whether rows can run in one call: the estimator's batch ready, the terrain steady."""
        return (
            self._steps.batch() is not None
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


def _filter_steps(config: Config, estimator: Estimator, priors: IcrPriors | None) -> FilterSteps:
    """Return the steps of ``estimator`` set up from ``config`` (``priors``: ICR EKF only)."""
    if estimator not in ESTIMATORS:
        raise ConfigError(f"unknown estimator {estimator!r}; choose one of {list(ESTIMATORS)}")
    mounting = _mounting(config)
    if estimator == "icr-ekf":
        icr_ekf = IcrEkf(
            config.ekf,
            config.terrain,
            priors=priors,
            mounting=mounting,
            robot=config.robot,
            heading_bias=HeadingBias.from_config(config.pose_sensor),
        )
        return IcrSteps(icr_ekf)
    if priors is not None or config.pose_sensor.heading_bias:
        raise ConfigError(
            "priors seed the ICR EKF (estimator icr-ekf); the slip EKF's parameters "
            "l1 .. l6 are not ICRs"
            if priors is not None
            else "pose_sensor.heading_bias is a state of the ICR EKF only: use "
            "estimator icr-ekf, or set it false"
        )
    from terrain_odom.estimation.slip_ekf import SlipEkf  # the slip EKF loads only when chosen
    from terrain_odom.estimation.slip_steps import SlipSteps

    return SlipSteps(SlipEkf(config.slip_ekf, config.robot.track_width, config.terrain), mounting)


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


def _after(first: float, values: np.ndarray) -> np.ndarray:
    """``first``, then ``values`` but the last: each row's predecessor."""
    return np.concatenate(([first], values[:-1]))


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
    return (*pair, YAW) if finite[YAW] else pair


def _finite(value: float, what: str, name: str, t: float | None = None) -> float:
    """Return ``value`` as a float, or raise naming it if it is not finite."""
    number = float(value)
    if not math.isfinite(number):
        at = "" if t is None else f" t={t!r} s:"
        raise ValueError(f"{what} at{at} {name}={value!r} is not finite")
    return number

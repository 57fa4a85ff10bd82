"""Self-calibration of the pose sensors before a run: the ``auto`` values of a configuration.

:func:`calibrate_config` resolves, from the whole log and before any
filtering, every ``auto`` of ``time`` (pose, position and heading delays)
and ``pose_sensor`` (heading offset, antenna, noise), or with
``everything`` every value the log can give (``terrain-odom calibrate``).
Each value found carries its standard error and how it was found, for the
comments of the written ``config.yaml`` and the report. A value asked as
``auto`` that the log cannot give stops with one line saying what data
would give it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from terrain_odom.config import Config
from terrain_odom.config.sections import PoseChangeSigmas, PoseSigmas, RobotConfig
from terrain_odom.errors import ConfigError, EstimationError, InputFileError
from terrain_odom.estimation.time_offset import (
    PoseDelayEstimate,
    TimeCalibration,
    delay_sensors,
    estimate_pose_delay,
)
from terrain_odom.evaluation import check_log
from terrain_odom.evaluation.calibration import Estimate, SensorFit, fit_sensors
from terrain_odom.evaluation.mounting import MountingLimits, fit_mounting
from terrain_odom.records import WheelLog

__all__ = [
    "Found",
    "SensorCalibration",
    "calibrate_config",
    "calibrate_inputs",
    "check_heading_bias",
    "check_plausible",
    "apply_delays",
    "robot_geometry",
]


@dataclass(frozen=True)
class Found:
    """One calibrated configuration value.

    Attributes
    ----------
    key : str
        Dotted configuration key (``pose_sensor.antenna_x``).
    value : float
        Value found (NaN: not observable; the configuration keeps its own).
    std : float
        Standard error, in the key's unit.
    unit : str
        ``s``, ``m`` or ``rad``.
    how : str
        How it was found, or why the log cannot give it.
    applied : bool
        Whether the value was written into the configuration.
    """

    key: str
    value: float
    std: float
    unit: str
    how: str
    applied: bool

    def comment(self) -> str:
        """Return the comment of the key's line in a written ``config.yaml``."""
        if not np.isfinite(self.value):
            return f"not observable: {self.how}"
        std = f" +- {self.std:.3g} {self.unit}" if np.isfinite(self.std) else ""
        return f"calibrated{std}: {self.how}"

    def line(self) -> str:
        """Return one printed line."""
        if not np.isfinite(self.value):
            return f"{self.key}: not observable: {self.how}"
        std = f" +- {self.std:.3g}" if np.isfinite(self.std) and self.std > 0 else ""
        deg = f" ({np.degrees(self.value):+.1f} deg)" if self.unit == "rad" else ""
        note = "" if self.applied else " (not used: the configuration's value is larger)"
        return f"{self.key}: {self.value:+.3f}{std} {self.unit}{deg}{note}, {self.how}"


@dataclass(frozen=True)
class SensorCalibration:
    """What :func:`calibrate_config` found.

    Attributes
    ----------
    found : tuple of Found
    notes : tuple of str
        One line each where an estimate overrides a configured value (a
        noise a message covariance understated).
    yaw_scale : float
        Measured turn / ideal differential drive's turn (NaN without a fit).
    """

    found: tuple[Found, ...] = ()
    notes: tuple[str, ...] = ()
    yaw_scale: float = float("nan")

    def comments(self) -> dict[str, str]:
        """Comments by dotted key for :func:`~terrain_odom.config.dump_config`."""
        return {f.key: f.comment() for f in self.found}

    def to_dict(self) -> dict[str, Any]:
        """Plain data for ``report.json`` / ``calibration.json``."""

        def num(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        return {
            "values": {
                f.key: {
                    "value": num(f.value),
                    "std": num(f.std),
                    "unit": f.unit,
                    "observable": bool(np.isfinite(f.value)),
                    "applied": f.applied,
                    "how": f.how,
                }
                for f in self.found
            },
            "notes": list(self.notes),
            "yaw_rate_scale": num(self.yaw_scale),
        }


def _separate_sensors(log: WheelLog) -> bool:
    """Whether positions and headings come on rows of their own (a GPS and an IMU)."""
    pos, yaw = log.has_position, log.has_yaw
    return bool(np.any(pos & ~yaw)) and bool(np.any(yaw & ~pos))


def calibrate_config(
    log: WheelLog, config: Config, *, everything: bool = False
) -> tuple[Config, SensorCalibration, TimeCalibration]:
    """Resolve the ``auto`` values of ``config`` from ``log`` (see the module).

    Parameters
    ----------
    log : WheelLog
        The log as recorded (speeds in m/s, no delay applied).
    config : Config
    everything : bool
        Estimate every value the log can give, not only the ``auto`` ones
        (values it cannot give keep the configuration's, unless ``auto``).

    Returns
    -------
    (Config, SensorCalibration, TimeCalibration)
        The configuration with numbers for its ``auto`` values, what was
        found, and the delays to apply (:func:`apply_delays`).

    Raises
    ------
    InputFileError
        An ``auto`` value the log cannot give (one line: what data would).
    """
    position_configured, heading_configured = config.time.delays
    sensor = config.pose_sensor
    wants = {
        "heading_delay": everything or heading_configured == "auto",
        "position_delay": everything or position_configured == "auto",
        "heading_offset": everything or sensor.heading_offset == "auto",
        "antenna": everything or "auto" in (sensor.antenna_x, sensor.antenna_y),
        "noise": everything or sensor.noise == "auto",
    }
    if not any(wants.values()):
        return config, SensorCalibration(), TimeCalibration(_number(position_configured), None)
    _require_data(log, config, wants)
    found: list[Found] = []
    heading_delay, heading_est = _heading_delay(log, config, wants["heading_delay"], found)
    position_given: float | None = _number(position_configured)
    if wants["position_delay"]:
        # one clock where the rows carry positions and headings together (as the heading says)
        own = _separate_sensors(log) or int(log.has_yaw.sum()) < 2
        position_given = None if own else heading_delay
    needs_fit = wants["antenna"] or wants["heading_offset"] or wants["noise"]
    fit = None
    if int(log.has_position.sum()) >= 2 and (needs_fit or position_given is None):
        fit = fit_sensors(
            log,
            config.robot.track_width,
            heading_delay=heading_delay,
            position_delay=position_given,
        )
    position_delay = _position_delay(fit, position_given, position_configured, wants, found, log)
    if int(log.has_yaw.sum()) < 2:
        heading_delay = position_delay  # no headings: one delay
    config = _with_delays(config, position_delay, heading_delay)
    notes: list[str] = []
    if fit is not None:
        delayed = delay_sensors(log, position_delay, heading_delay)
        config = _mounting(config, fit, wants, found, delayed)
        if wants["noise"]:
            config = _noise(config, fit, found, notes)
    elif wants["noise"]:
        notes.append(
            "noise not estimated: the log has no positions to compare the sensors with the "
            "wheels' path; ekf.sigma_r kept"
        )
    position_std = next(
        (f.std for f in found if f.key == "time.position_delay" and f.applied), None
    )
    timing = TimeCalibration(position_delay, heading_est, heading_delay, position_std)
    scale = fit.yaw_scale if fit is not None else float("nan")
    return config, SensorCalibration(tuple(found), tuple(notes), scale), timing


def apply_delays(log: WheelLog, timing: TimeCalibration) -> WheelLog:
    """Return ``log`` with the position and heading delays of ``timing`` applied."""
    return delay_sensors(log, timing.pose_delay, timing.heading_delay_applied)


def _number(value: float | str | None) -> float:
    return float(value) if value not in (None, "auto") else 0.0


def _require_data(log: WheelLog, config: Config, wants: dict[str, bool]) -> None:
    """Stop with one line when an ``auto`` needs rows the log does not have."""
    sensor = config.pose_sensor
    has_pos, has_yaw = int(log.has_position.sum()) >= 2, int(log.has_yaw.sum()) >= 2
    if not (has_pos or has_yaw):
        raise InputFileError(
            f"{log.source}: no pose rows (x, y or yaw) to calibrate against the wheels; "
            "record a GPS (positions) or an IMU (headings) with the wheel speeds"
        )
    if sensor.heading_offset == "auto" and not (has_yaw and has_pos):
        missing = "headings (an IMU's yaw)" if not has_yaw else "positions (a GPS)"
        raise InputFileError(
            f"{log.source}: pose_sensor.heading_offset auto needs positions and headings, the "
            f"log has no {missing}; record both, or give the offset in radians"
        )
    if "auto" in (sensor.antenna_x, sensor.antenna_y) and not has_pos:
        raise InputFileError(
            f"{log.source}: pose_sensor.antenna auto needs positions (a GPS) while turning; "
            "the log has none: give the antenna in metres"
        )
    if config.time.heading_delay == "auto" and not has_yaw:
        raise InputFileError(
            f"{log.source}: time.heading_delay auto needs heading rows (an IMU's yaw); the log "
            "has none: give seconds, or leave it null"
        )
    if _still(log):
        raise InputFileError(
            f"{log.source}: the wheels barely move (less than 5 m of travel): nothing to "
            "calibrate against; record the robot driving, with turns, for a few minutes"
        )


def _still(log: WheelLog) -> bool:
    dt = np.diff(log.t) * (np.diff(log.segment_runs()) == 0)
    travel = float(np.sum(np.abs(0.5 * (log.v_l + log.v_r))[:-1] * dt))
    return travel < 5.0


def _heading_delay(
    log: WheelLog, config: Config, want: bool, found: list[Found]
) -> tuple[float, PoseDelayEstimate | None]:
    """Return the heading delay: estimated from the heading changes, or as configured."""
    _, configured = config.time.delays
    if not want or int(log.has_yaw.sum()) < 2:
        return _number(configured), None
    try:
        est = estimate_pose_delay(log, config.robot.track_width)
    except EstimationError as exc:
        if configured == "auto":
            raise InputFileError(
                f"{exc}; the delay of the headings needs turns of changing rate"
            ) from None
        found.append(Found("time.heading_delay", np.nan, np.nan, "s", str(exc), False))
        return _number(configured), None
    how = f"heading changes against the wheels' turn ({est.pairs} changes)"
    found.append(Found("time.heading_delay", est.delay, est.std, "s", how, True))
    return est.delay, est


def _position_delay(
    fit: SensorFit | None,
    given: float | None,
    configured: float | str,
    wants: dict[str, bool],
    found: list[Found],
    log: WheelLog,
) -> float:
    """Return the position delay: the fit's estimate, or ``given``."""
    if given is not None:
        return given
    est = fit.position_delay if fit is not None else None
    if est is None or not est.observable:
        why = est.how if est is not None else "the log has no positions"
        if configured == "auto":
            raise InputFileError(f"{log.source}: time.position_delay auto: {why}")
        found.append(Found("time.position_delay", np.nan, np.nan, "s", why, False))
        return _number(configured)
    found.append(Found("time.position_delay", est.value, est.std, "s", est.how, True))
    return est.value


def _with_delays(config: Config, position: float, heading: float) -> Config:
    """``config`` with its delays as numbers (one ``pose_delay`` when they are equal)."""
    if position == heading:
        time = dataclasses.replace(
            config.time, pose_delay=position, position_delay=None, heading_delay=None
        )
    else:
        time = dataclasses.replace(
            config.time, pose_delay=position, position_delay=position, heading_delay=heading
        )
    return dataclasses.replace(config, time=time)


def _mounting(
    config: Config, fit: SensorFit, wants: dict[str, bool], found: list[Found], log: WheelLog
) -> Config:
    """Heading offset and antenna from the fit (``auto`` ones required)."""
    sensor = config.pose_sensor
    changes: dict[str, Any] = {}
    picks = []
    if wants["heading_offset"] and int(log.has_yaw.sum()) >= 2:
        offset = fit.heading_offset
        if not offset.observable:  # too few windows: the straight chords, as the check
            offset = _chord_offset(log, config.robot.track_width, offset)
        picks.append(("heading_offset", offset, "rad"))
    if wants["antenna"]:
        picks += [("antenna_x", fit.antenna_x, "m"), ("antenna_y", fit.antenna_y, "m")]
    for name, est, unit in picks:
        _check_auto(getattr(sensor, name), est, f"pose_sensor.{name}", log)
        found.append(
            Found(f"pose_sensor.{name}", est.value, est.std, unit, est.how, est.observable)
        )
        if est.observable:
            changes[name] = float(est.value)
    return dataclasses.replace(config, pose_sensor=dataclasses.replace(sensor, **changes))


def _chord_offset(log: WheelLog, track_width: float, windows: Estimate) -> Estimate:
    """Return the heading offset over straight chords where the windows cannot give it.

    ``log`` has its delays applied. Enough straight chords for the check to
    judge them (:class:`~terrain_odom.evaluation.mounting.MountingLimits`),
    else ``windows`` (not observable) is returned.
    """
    lim = MountingLimits()
    fit = fit_mounting(log, track_width, limits=lim)
    n = fit.straight
    if not (np.isfinite(fit.heading_offset) and n >= lim.min_judged):
        return windows
    std = fit.heading_spread * float(np.sqrt(fit.correlation / n))
    how = (
        f"circular median of measured heading minus course over {n} straight chords of "
        f"{lim.chord:g} m ({windows.how.split(':')[0]}, too few for the windows' fit)"
    )
    return Estimate(fit.heading_offset, std, True, how)


def _check_auto(configured: float | str, est: Estimate, key: str, log: WheelLog) -> None:
    if configured == "auto" and not est.observable:
        raise InputFileError(f"{log.source}: {key} auto: {est.how}")


def _noise(config: Config, fit: SensorFit, found: list[Found], notes: list[str]) -> Config:
    """Raise ``ekf.sigma_r`` (and ``slip_ekf.sigma_r``) to the noise found where it claims less."""
    sigma = config.ekf.sigma_r
    x, yaw = sigma.x, sigma.yaw
    pos = fit.position_noise
    if pos.observable:
        use = pos.value > max(sigma.x, sigma.y)
        notes.append(
            f"GPS noise {pos.value:.2f} m (claimed {max(sigma.x, sigma.y):.2f} m): using "
            f"{max(pos.value, sigma.x, sigma.y):.2f}"
        )
        for key in ("ekf.sigma_r.x", "ekf.sigma_r.y"):
            found.append(Found(key, pos.value, pos.std, "m", pos.how, use))
        x = float(max(pos.value, sigma.x, sigma.y))
    white, wander = fit.heading_noise, fit.heading_wander
    if white.observable:
        total = float(np.hypot(white.value, wander.value if wander.observable else 0.0))
        how = (
            f"white {white.value:.3f} rad ({white.how}) and slow wander "
            f"{wander.value if wander.observable else float('nan'):.3f} rad in quadrature"
        )
        use = total > sigma.yaw
        notes.append(
            f"heading noise {total:.3f} rad = {np.degrees(total):.1f} deg (claimed "
            f"{np.degrees(sigma.yaw):.1f} deg): using {np.degrees(max(total, sigma.yaw)):.1f}"
        )
        found.append(Found("ekf.sigma_r.yaw", total, white.std, "rad", how, use))
        yaw = float(max(total, sigma.yaw))
    ekf = dataclasses.replace(config.ekf, sigma_r=PoseSigmas(x, max(x, sigma.y), yaw))
    change = PoseChangeSigmas(
        *(
            float(max(a, np.sqrt(2.0) * b))
            for a, b in zip(
                (
                    config.slip_ekf.sigma_r.dx,
                    config.slip_ekf.sigma_r.dy,
                    config.slip_ekf.sigma_r.dyaw,
                ),
                (x, max(x, sigma.y), yaw),
                strict=True,
            )
        )
    )
    slip = dataclasses.replace(config.slip_ekf, sigma_r=change)
    sensor = dataclasses.replace(config.pose_sensor, noise="config")
    return dataclasses.replace(config, ekf=ekf, slip_ekf=slip, pose_sensor=sensor)


def check_heading_bias(config: Config, has_positions: bool, source: str) -> None:
    """Refuse the ICR EKF's heading-bias state where no positions come (one line).

    Only the positions' course tells a heading's slow bias from the yaw:
    with headings alone nothing observes it, and the wheels' disagreement
    with the heading is shared between the bias and the ICRs.

    Raises
    ------
    ConfigError
        ``pose_sensor.heading_bias`` is on and ``has_positions`` is false;
        ``source`` names the log or the topics.
    """
    if config.pose_sensor.heading_bias and not has_positions:
        raise ConfigError(
            f"{source}: headings but no positions: pose_sensor.heading_bias needs both (only "
            "the positions' course tells a heading's slow bias from the yaw); set it false"
        )


def calibrate_inputs(
    log: WheelLog, config: Config, *, everything: bool = False
) -> tuple[WheelLog, Config, SensorCalibration, TimeCalibration]:
    """Resolve ``config``'s ``auto`` values from ``log``, apply its delays, then check it.

    The checks (:func:`check_plausible`) judge the log with the values
    found applied, so they never refuse what ``auto`` produced; where the
    calibration itself fails on a log the checks explain better (a unit
    mistake), their finding is raised instead.

    Parameters
    ----------
    log : WheelLog
        As read (speeds in m/s).
    config : Config
    everything : bool
        Estimate every value the log gives (``terrain-odom calibrate``).

    Returns
    -------
    (WheelLog, Config, SensorCalibration, TimeCalibration)
        The log with its delays applied, the resolved configuration, what
        was found, and the delays.

    Raises
    ------
    ConfigError
        ``pose_sensor.heading_bias`` on a log without positions
        (:func:`check_heading_bias`).
    """
    check_heading_bias(config, bool(log.has_position.any()), log.source)
    try:
        resolved, found, timing = calibrate_config(log, config, everything=everything)
    except (InputFileError, EstimationError):
        unjudged = Found("pose_sensor.heading_offset", np.nan, np.nan, "rad", "", False)
        lever = dataclasses.replace(unjudged, key="pose_sensor.antenna_x")
        # a unit mistake explains the failure better (the mounting is not judged)
        check_plausible(log, _numbers(config), SensorCalibration((unjudged, lever)))
        raise
    delayed = apply_delays(log, timing)
    notes = check_plausible(delayed, resolved, found)
    found = dataclasses.replace(found, notes=(*found.notes, *notes))
    return delayed, resolved, found, timing


def _numbers(config: Config) -> Config:
    """``config`` with its ``auto`` mounting as 0 (for the checks of an uncalibrated log)."""
    sensor = config.pose_sensor
    numbers: dict[str, Any] = {
        k: 0.0 for k in ("antenna_x", "antenna_y", "heading_offset") if getattr(sensor, k) == "auto"
    }
    return dataclasses.replace(config, pose_sensor=dataclasses.replace(sensor, **numbers))


def check_plausible(
    log: WheelLog, config: Config, found: SensorCalibration | None = None
) -> list[str]:
    """Stop on the first finding of :func:`~terrain_odom.evaluation.check_log` (if ``config.checks``).

    ``found``: what a calibration found. A mounting it looked at is not
    judged again (it is measured, or reported not observable, by a finer
    fit than the checks' chords): such findings are returned instead (one
    line each) for the calibration's notes. Its position noise shortens the
    measured path of a slow robot in the travel check.

    Raises
    ------
    InputFileError
        One line: the finding, the robot geometry it was judged with, and the way out.
    """
    if not config.checks.enabled:
        return []
    sensor = config.pose_sensor
    looked = {f.key for f in found.found} if found is not None else set()
    noise = config.ekf.sigma_r.x if "ekf.sigma_r.x" in looked else 0.0
    result = check_log(
        log,
        config.robot.track_width,
        antenna=(float(sensor.antenna_x), float(sensor.antenna_y)),
        heading_offset=float(sensor.heading_offset),
        position_noise=noise,
    )
    skip = set()
    if "pose_sensor.heading_offset" in looked:
        skip.add("heading_offset")
    if looked & {"pose_sensor.antenna_x", "pose_sensor.antenna_y"}:
        skip.add("lever_arm")
    refused = [f for f in result.findings if f.check not in skip]
    if refused:
        raise InputFileError(
            f"{log.source}: {refused[0].message} ({robot_geometry(config.robot)}); "
            "--no-checks runs anyway"
        )
    return [f"check {f.check}: {f.message}" for f in result.findings if f.check in skip]


def robot_geometry(robot: RobotConfig) -> str:
    """Return the geometry a log is judged and calibrated with, as the messages name it.

    Examples
    --------
    >>> robot_geometry(RobotConfig())
    'wheel radius 0.1 m, track width 0.5 m'
    """
    return f"wheel radius {robot.wheel_radius:g} m, track width {robot.track_width:g} m"

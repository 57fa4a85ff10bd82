"""The configuration a bag gives: robot geometry, pose noise, sensor and camera mountings.

From the streams of one pass over a bag (:class:`~terrain_odom.io.bag.streams.BagStreams`):
the pose noise of the message covariances (``ekf.sigma_r``,
``slip_ekf.sigma_r``), the pose sensors' and the camera's mounting from
``/tf_static``, the camera intrinsics; the keys the bag cannot tell are
listed to fill by hand, and where each value came from is kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from terrain_odom.config.loader import read_yaml
from terrain_odom.errors import InputFileError
from terrain_odom.io.bag.messages import (
    NAV_SAT_FIX,
    TF_STATIC,
    camera_mount,
    chain_transform,
    sensor_mounting,
)
from terrain_odom.io.bag.options import ImportOptions
from terrain_odom.io.bag.streams import BagStreams
from terrain_odom.kinematics import wrap_angle

__all__ = ["BagConfig", "bag_config"]

ANTENNA_KEYS = ("pose_sensor.antenna_x", "pose_sensor.antenna_y")
CAMERA_MOUNT_KEYS = (
    "camera.mount_x",
    "camera.mount_y",
    "camera.mount_height",
    "camera.mount_pitch",
    "camera.mount_yaw",
)


@dataclass(frozen=True)
class BagConfig:
    """The configuration a bag gives, before it is validated and written.

    Attributes
    ----------
    data : dict
        The configuration's sections (``--config``'s, with what the bag told).
    header : tuple of str
        The comment lines of ``config.yaml``'s top (where the mountings came
        from, the keys to fill).
    fill_keys : tuple of str
        Configuration keys the bag could not tell (to fill by hand).
    sources : dict of str to str
        Where each configuration value the import set came from (an
        option, a topic's messages, ``/tf_static``), by key.
    """

    data: dict[str, Any]
    header: tuple[str, ...]
    fill_keys: tuple[str, ...]
    sources: dict[str, str]


def bag_config(
    streams: BagStreams,
    options: ImportOptions,
    robot: dict[str, float | None],
    bag: str | Path,
) -> BagConfig:
    """Return the configuration the bag gives: ``--config``'s, with what the streams told.

    Raises
    ------
    InputFileError
        A pose topic and a heading topic measuring the yaw of frames turned
        from each other (one ``heading_offset`` cannot serve both).
    """
    data: dict[str, Any] = (
        dict(read_yaml(Path(options.config_path)) or {}) if options.config_path else {}
    )
    fill = ["robot.track_width"] if robot["track_width"] is None else []
    data["robot"] = {**data.get("robot", {}), **{k: v for k, v in robot.items() if v is not None}}
    sources = {
        f"robot.{k}": f"--{k.replace('_', '-')}" if getattr(options, k) else "--config"
        for k, v in robot.items()
        if v is not None
    }
    _pose_noise(data, streams, options, sources)
    header = [f"# terrain-odom import of {bag}"]
    fill += _pose_sensor(data, streams, options, sources)
    if any(key.startswith("pose_sensor.") and "/tf_static" in v for key, v in sources.items()):
        header.append(
            f"# pose_sensor.* from {TF_STATIC} (the sensors' frames in {options.base_frame}); "
            "a heading's magnetic declination is not in it (heading_offset: auto estimates both)"
        )
    if options.image_topic is not None:
        mount = _mount(streams, options.base_frame)
        fill += _camera(data, streams, mount, options.base_frame, sources)
        if mount is not None:
            header.append(
                f"# camera.mount_* from {TF_STATIC} ({options.base_frame} -> "
                f"{streams.image_frame}); mount_height is above {options.base_frame}'s origin: "
                "add its height above the ground unless it is on the ground"
            )
    if fill:
        header.append("# FILL IN (the bag does not tell them): " + ", ".join(fill))
    return BagConfig(data, tuple(header), tuple(fill), sources)


def _pose_noise(
    data: dict[str, Any], streams: BagStreams, options: ImportOptions, sources: dict[str, str]
) -> None:
    """Set ``ekf.sigma_r`` and ``slip_ekf.sigma_r`` from the message covariances that give one.

    Per component: ``x, y`` from the position covariance, ``yaw`` from the
    yaw variance (of the pose topic, else of the Imu's orientation). The slip
    EKF measures the change between two poses, whose independent errors add:
    its ``dx, dy, dyaw`` are sqrt(2) times the pose's.
    """
    found = streams.poses.sigma() if streams.poses else {}
    sigma = {key: float(f"{value:.6g}") for key, value in found.items()}
    for key in sigma:
        n = len(streams.poses.sigmas) if streams.poses else 0
        sources[f"ekf.sigma_r.{key}"] = f"{options.pose_topic} covariances (median of {n})"
    yaw = streams.headings.sigma() if streams.headings else None
    if yaw is not None and "yaw" not in sigma and streams.headings is not None:
        sigma["yaw"] = float(f"{yaw:.6g}")
        sources["ekf.sigma_r.yaw"] = (
            f"{options.heading_topic} orientation covariances (median of "
            f"{len(streams.headings.sigmas)})"
        )
    if not sigma:
        return
    ekf = data.setdefault("ekf", {})
    ekf["sigma_r"] = {**ekf.get("sigma_r", {}), **sigma}
    change = {f"d{key}": float(f"{math.sqrt(2.0) * value:.6g}") for key, value in sigma.items()}
    slip = data.setdefault("slip_ekf", {})
    slip["sigma_r"] = {**slip.get("sigma_r", {}), **change}
    for key in sigma:
        sources[f"slip_ekf.sigma_r.d{key}"] = (
            f"sqrt(2) ekf.sigma_r.{key} (the change between two independent measurements)"
        )


def _pose_sensor(
    data: dict[str, Any], streams: BagStreams, options: ImportOptions, sources: dict[str, str]
) -> list[str]:
    """Set ``pose_sensor`` from ``/tf_static``; return the keys to fill (a GPS antenna not in it).

    The antenna is the pose sensor's frame origin in the base frame; the
    heading offset is the yaw of the frame whose yaw is measured (the Imu's,
    or the pose's) in the base frame (:func:`sensor_mounting`).
    """
    base = options.base_frame.lstrip("/")
    sensor, fill, pose_yaw = _antenna(streams, options, base, sources)
    offsets = dict([pose_yaw]) if pose_yaw is not None else {}
    if streams.headings is not None:
        frame = streams.headings.sensor_frame or base
        mount = chain_transform(streams.static, base, frame)
        offsets[frame] = None if mount is None else sensor_mounting(mount)[2]
    offset = _heading_offset(offsets, options, base)
    if offset is not None:
        sensor["heading_offset"] = offset[1]
        sources["pose_sensor.heading_offset"] = f"{TF_STATIC} {base} -> {offset[0]} (yaw)"
    if sensor:
        data["pose_sensor"] = {**data.get("pose_sensor", {}), **sensor}
    return fill


def _antenna(
    streams: BagStreams, options: ImportOptions, base: str, sources: dict[str, str]
) -> tuple[dict[str, float], list[str], tuple[str, float | None] | None]:
    """Return the antenna keys ``/tf_static`` gives, the keys to fill, the pose's yaw frame.

    The last: the frame whose yaw the pose topic measures and its yaw in the
    base frame (None if ``/tf_static`` does not tell); None for a GPS (no yaw).
    """
    poses = streams.poses
    if poses is None or options.pose_topic is None:
        return {}, [], None
    gps = streams.types[options.pose_topic] == NAV_SAT_FIX
    frame = poses.sensor_frame
    if frame is None and gps:
        sources.update(dict.fromkeys(ANTENNA_KEYS, "not set: the NavSatFix names no frame"))
        return {}, list(ANTENNA_KEYS), None
    if frame is None or frame == base:
        return {}, [], None if gps else (base, 0.0)
    mount = chain_transform(streams.static, base, frame)
    where = f"{TF_STATIC} {base} -> {frame}"
    if mount is None:
        sources.update(dict.fromkeys(ANTENNA_KEYS, f"not set: {where} not in the bag"))
        return {}, list(ANTENNA_KEYS) if gps else [], None if gps else (frame, None)
    antenna_x, antenna_y, yaw = sensor_mounting(mount)
    sources.update(dict.fromkeys(ANTENNA_KEYS, where))
    return {"antenna_x": antenna_x, "antenna_y": antenna_y}, [], None if gps else (frame, yaw)


def _heading_offset(
    offsets: dict[str, float | None], options: ImportOptions, base: str
) -> tuple[str, float] | None:
    """Return the frame and yaw (rad) measured headings are offset by, if ``/tf_static`` tells.

    Raises
    ------
    InputFileError
        If the pose's yaw and the Imu's are of frames turned from each other
        (one ``heading_offset`` cannot serve both).
    """
    known = {frame: yaw for frame, yaw in offsets.items() if yaw is not None}
    if len(known) == 2:
        (pose_frame, pose_yaw), (imu_frame, imu_yaw) = known.items()
        turn = float(wrap_angle(imu_yaw - pose_yaw))
        if abs(turn) > 1e-6:
            raise InputFileError(
                f"--pose-topic {options.pose_topic} measures the yaw of {pose_frame}, "
                f"--heading-topic {options.heading_topic} of {imu_frame}, turned "
                f"{math.degrees(turn):+.1f} deg from it ({TF_STATIC}): one "
                "pose_sensor.heading_offset cannot serve both; import one of them"
            )
    turned = [(frame, yaw) for frame, yaw in known.items() if frame != base]
    return turned[-1] if turned else None


def _mount(streams: BagStreams, base_frame: str) -> dict[str, float] | None:
    """Return the camera mounting from ``/tf_static`` (base frame -> the image frame), if there."""
    frame = streams.image_frame
    pose = chain_transform(streams.static, base_frame.lstrip("/"), frame) if frame else None
    if pose is None or frame is None:
        return None
    return camera_mount(pose, optical="optical" in frame)


def _camera(
    data: dict[str, Any],
    streams: BagStreams,
    mount: dict[str, float] | None,
    base_frame: str,
    sources: dict[str, str],
) -> list[str]:
    """Set the camera intrinsics and mounting that are known; return the camera keys to fill."""
    fill: list[str] = []
    known: dict[str, Any] = {}
    camera = streams.camera
    if camera is None:
        fill += [f"camera.{k}" for k in ("width", "height", "fx", "fy", "cx", "cy")]
    else:
        known.update({k: getattr(camera, k) for k in ("width", "height", "fx", "fy", "cx", "cy")})
    if mount is None:
        fill += CAMERA_MOUNT_KEYS
    else:
        known.update(mount)
    if known:
        data["camera"] = {**data.get("camera", {}), **known}
    for key in known:
        sources[f"camera.{key}"] = (
            f"{TF_STATIC} {base_frame} -> {streams.image_frame}"
            if key.startswith("mount_")
            else f"{streams.camera_topic} (CameraInfo)"
        )
    return fill

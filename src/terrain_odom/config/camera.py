"""Camera and region-of-interest configuration (pure data, validated on construction).

The models that use them are in :mod:`terrain_odom.vision.camera`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from terrain_odom.config.fields import NON_NEGATIVE, SIGNED
from terrain_odom.errors import ConfigError

__all__ = ["CameraConfig", "RoiConfig"]


@dataclass(frozen=True)
class CameraConfig:
    """A camera looking at the ground: intrinsics + mounting, or a homography.

    Attributes
    ----------
    width, height : int
        Image size, px.
    fx, fy : float
        Focal lengths, px.
    cx, cy : float
        Principal point, px (pixel centres at integer coordinates).
    mount_x, mount_y : float
        Position of the optical centre in the robot frame, m.
    mount_height : float
        Height of the optical centre above the ground, m.
    mount_pitch : float
        Downward tilt of the optical axis below the horizontal, rad, in
        ``(-pi/2, pi/2]`` (> 0 looks down, ``pi/2`` straight down).
    mount_yaw : float
        Direction of the optical axis, rad counter-clockwise from the robot's
        x axis, in ``[-pi, pi]``.
    homography : tuple of 9 float, optional
        Row-major 3 x 3 map of ground points ``(x, y, 1)`` (robot frame, m) to
        pixels ``(u, v, 1)``, any nonzero scale. When given, it replaces the
        intrinsics and the mounting (``width, height`` still apply).

    Raises
    ------
    ConfigError
        If the pitch or yaw is out of range or the homography is not an
        invertible 3 x 3 matrix.
    """

    width: int = 640
    height: int = 480
    fx: float = 500.0
    fy: float = 500.0
    cx: float = field(default=319.5, metadata=NON_NEGATIVE)
    cy: float = field(default=239.5, metadata=NON_NEGATIVE)
    mount_x: float = field(default=0.2, metadata=SIGNED)
    mount_y: float = field(default=0.0, metadata=SIGNED)
    mount_height: float = 0.5
    mount_pitch: float = field(default=math.pi / 4, metadata=SIGNED)
    mount_yaw: float = field(default=0.0, metadata=SIGNED)
    homography: tuple[float, ...] | None = field(default=None, metadata=SIGNED)

    def __post_init__(self) -> None:
        if not -math.pi / 2 < self.mount_pitch <= math.pi / 2:
            raise ConfigError(f"mount_pitch: must be in (-pi/2, pi/2] rad, got {self.mount_pitch}")
        if not -math.pi <= self.mount_yaw <= math.pi:
            raise ConfigError(f"mount_yaw: must be in [-pi, pi] rad, got {self.mount_yaw}")
        if self.homography is not None:
            if len(self.homography) != 9:
                raise ConfigError(
                    f"homography: must hold 9 numbers (row-major 3x3), got {len(self.homography)}"
                )
            sv = np.linalg.svd(np.reshape(self.homography, (3, 3)), compute_uv=False)
            if not sv[-1] > 1e-12 * sv[0]:
                raise ConfigError("homography: the matrix is singular (not invertible)")


@dataclass(frozen=True)
class RoiConfig:
    """Region of interest: the robot's footprint ``horizon`` seconds ahead.

    Attributes
    ----------
    horizon : float
        ``t_s``: how far ahead the pose is predicted, s (0: the current pose).
    footprint_length, footprint_width : float
        Robot length ``W`` (along x) and width ``B`` (along y), m.
    expand : float
        Factor applied to both (Chen: 1.2, giving ``W_1, B_1``).
    min_size : int
        Smallest usable box side, px; a smaller visible region is reported as
        :attr:`RoiStatus.TOO_SMALL` (SFTA needs at least 8 x 8 pixels).
    """

    horizon: float = field(default=1.0, metadata=NON_NEGATIVE)
    footprint_length: float = 0.6
    footprint_width: float = 0.5
    expand: float = 1.2
    min_size: int = 8

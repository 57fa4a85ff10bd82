"""Camera frames rendered by projecting the ground map through the camera model.

For a robot at pose ``(x, y, yaw)`` the map is warped into the image by

    H = H_cam @ T_robot<-world @ M_world<-map

where ``M`` maps map pixels to world metres
(:attr:`~terrain_odom.sim.world.GroundMap.pixel_to_world`), ``T`` is the
inverse of the robot pose, and ``H_cam`` is the ground-to-image homography in
the robot frame (:attr:`terrain_odom.vision.camera.GroundCamera.homography`).
``cv2.warpPerspective`` samples the map at ``H^-1`` of every image pixel
(bilinear). Pixels whose ray never meets the ground (on or above the horizon)
are filled with a flat sky grey. Lighting changes slowly (a gain of
``1 + amplitude * sin(2 pi t / period + phase)``) and every pixel gets white
sensor noise; both can be turned off for tests.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.sim.world import GroundMap
from terrain_odom.vision.camera import GroundCamera

__all__ = ["SKY_GREY", "Lighting", "world_to_robot", "frame_homography", "Renderer"]

SKY_GREY = 200
"""Grey level of image pixels that see no ground."""


@dataclass(frozen=True)
class Lighting:
    """Photometric variation of the frames.

    Attributes
    ----------
    amplitude : float
        Relative amplitude of the slow gain change (0: constant).
    period : float
        Period of the gain change, s.
    phase : float
        Phase of the gain change, rad.
    noise : float
        Std of the white sensor noise, grey levels (0-255).
    """

    amplitude: float = 0.08
    period: float = 17.0
    phase: float = 0.0
    noise: float = 2.0

    def gain(self, t: float) -> float:
        """Brightness gain at time ``t`` (s)."""
        return 1.0 + self.amplitude * float(np.sin(2.0 * np.pi * t / self.period + self.phase))


def world_to_robot(pose: ArrayLike) -> np.ndarray:
    """3 x 3 map of world points ``(x, y, 1)`` into the frame of a robot at ``pose``.

    Examples
    --------
    >>> (world_to_robot([1.0, 2.0, np.pi / 2]) @ [1.0, 3.0, 1.0]).round(12).tolist()
    [1.0, 0.0, 1.0]
    """
    x, y, yaw = np.asarray(pose, dtype=float)
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, s, -c * x - s * y], [-s, c, s * x - c * y], [0.0, 0.0, 1.0]])


def frame_homography(camera: GroundCamera, ground: GroundMap, pose: ArrayLike) -> np.ndarray:
    """Homography from map pixels to image pixels for a robot at ``pose`` (m, m, rad)."""
    return camera.homography @ world_to_robot(pose) @ ground.pixel_to_world


class Renderer:
    """Renders what the camera of a robot sees of a ground map.

    Parameters
    ----------
    ground : GroundMap
        The world.
    camera : GroundCamera
        Camera model (robot frame).
    lighting : Lighting, optional
        Photometric variation; ``Lighting(0, noise=0)`` renders the map exactly.
    """

    def __init__(self, ground: GroundMap, camera: GroundCamera, lighting: Lighting | None = None):
        self.ground = ground
        self.camera = camera
        self.lighting = Lighting() if lighting is None else lighting
        u, v = np.meshgrid(np.arange(camera.width), np.arange(camera.height))
        ground_xy = camera.backproject(np.stack([u, v], axis=-1).astype(float))
        self._sky = ~np.isfinite(ground_xy[..., 0])

    def render(self, pose: ArrayLike, t: float = 0.0, rng: np.random.Generator | None = None):
        """Render one RGB frame, uint8, shape (height, width, 3).

        Parameters
        ----------
        pose : array_like, shape (3,)
            Robot pose (m, m, rad).
        t : float
            Time, s (for the lighting).
        rng : numpy.random.Generator, optional
            Sensor noise; required when ``lighting.noise > 0``.
        """
        h = frame_homography(self.camera, self.ground, pose)
        size = (self.camera.width, self.camera.height)
        image = cv2.warpPerspective(
            self.ground.image, h, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101
        )
        image[self._sky] = SKY_GREY
        gain, sigma = self.lighting.gain(t), self.lighting.noise
        if gain == 1.0 and sigma == 0.0:
            return image
        out = image.astype(np.float32) * np.float32(gain)
        if sigma > 0.0:
            if rng is None:
                raise ValueError("rng is required for sensor noise")
            out += rng.normal(0.0, sigma, out.shape).astype(np.float32)
        return np.clip(np.rint(out), 0, 255).astype(np.uint8)

    def ground_points(self, uv: ArrayLike, pose: ArrayLike) -> np.ndarray:
        """World points (m) seen at image pixels ``uv`` (``(..., 2)``) from ``pose``; NaN above the horizon."""
        robot = self.camera.backproject(uv)
        x, y, yaw = np.asarray(pose, dtype=float)
        c, s = np.cos(yaw), np.sin(yaw)
        return np.stack(
            [x + c * robot[..., 0] - s * robot[..., 1], y + s * robot[..., 0] + c * robot[..., 1]],
            axis=-1,
        )

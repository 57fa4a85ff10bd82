"""Ground-plane camera model and the kinematics-predicted region of interest.

Chen et al. 2023, §3.2.2: the ground is a plane, so a pinhole camera maps
ground points of the robot frame to pixels by a homography (their eq. 17,
``f_trans``). To classify only the terrain the robot is about to drive on,
the robot's pose ``t_s`` seconds ahead is predicted with the current
kinematic model, its footprint expanded 1.2x (eq. 22's ``W_1, B_1``) is
placed there, and the image region it covers is cropped.

Frames and conventions
----------------------
- **Robot frame**: x forward, y left, z up, origin on the ground; metres.
- **Camera optical frame** (OpenCV): z along the optical axis, x to the
  right of the image, y down the image.
- **Pixels** ``(u, v)``: ``u`` along the image columns (right), ``v`` along
  the rows (down); pixel ``(i, j)`` has its centre at ``u = i, v = j`` and
  covers ``[i - 0.5, i + 0.5) x [j - 0.5, j + 0.5)`` (OpenCV's convention, so
  the exact centre of a 640 x 480 image is ``(319.5, 239.5)``).
- **Mounting**: the optical centre is at ``(mount_x, mount_y,
  mount_height)`` in the robot frame; the camera first looks along +x with
  the image upright, is then pitched down by ``mount_pitch`` about the
  robot's y axis, then yawed by ``mount_yaw`` (counter-clockwise) about z.
- **Homography** ``H`` (3 x 3, ground to image): ``s (u, v, 1) = H (x, y, 1)``.
  It is defined up to scale; its sign is normalised so that ``det(H) < 0``,
  which for any camera above the ground with ``fx, fy > 0`` makes ``s`` the
  (positive) depth of points in front of the camera: for
  ``H = K [r1 r2 t]``, ``det H = fx fy (r1 x r2) . t = -fx fy h``. Ground
  points with ``s <= 0`` are behind the camera and pixels whose ray never
  reaches the ground (on or above the horizon) have no ground point: both
  give NaN, never a wrong number.

Lens distortion is out of scope: undistort images first (``cv2.undistort``)
and give the intrinsics of the undistorted image.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.config import CameraConfig, RoiConfig
from terrain_odom.kinematics import arc_increment, twist_icr, wrap_angle

__all__ = [
    "CameraConfig",
    "RoiConfig",
    "GroundCamera",
    "RoiStatus",
    "RoiResult",
    "intrinsic_matrix",
    "mounting_extrinsics",
    "footprint_extent",
    "footprint_corners",
    "predict_pose",
    "region_of_interest",
    "crop",
]


# Rows: camera x = -robot y (right), camera y = -robot z (down), camera z = robot x.
_ROBOT_TO_OPTICAL = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


def intrinsic_matrix(config: CameraConfig) -> np.ndarray:
    """Return the pinhole camera matrix ``K``, shape (3, 3), px."""
    return np.array([[config.fx, 0.0, config.cx], [0.0, config.fy, config.cy], [0.0, 0.0, 1.0]])


def _rot_y(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def mounting_extrinsics(config: CameraConfig) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and translation from the robot frame to the camera optical frame.

    ``p_cam = R @ p_robot + t`` (the ``rvec, tvec`` of OpenCV, with
    ``rvec = cv2.Rodrigues(R)[0]``). The camera's orientation in the robot
    frame is ``Rz(mount_yaw) @ Ry(mount_pitch) @ R0.T``, where ``R0`` takes a
    forward-looking, upright camera's axes to the optical convention and
    ``Ry(+pitch)`` tilts the x axis down.

    Returns
    -------
    rotation : ndarray, shape (3, 3)
    translation : ndarray, shape (3,)
        m.

    Examples
    --------
    Looking straight down, the optical axis (row 2 of ``R``) is -z and the
    top of the image (-y of the camera, row 1 of ``R``) points forward:

    >>> r, t = mounting_extrinsics(CameraConfig(mount_pitch=np.pi / 2))
    >>> (r[2].round(12) + 0.0).tolist(), (-r[1].round(12) + 0.0).tolist()
    ([0.0, 0.0, -1.0], [1.0, 0.0, 0.0])
    """
    cam_to_robot = _rot_z(config.mount_yaw) @ _rot_y(config.mount_pitch) @ _ROBOT_TO_OPTICAL.T
    rotation = cam_to_robot.T
    centre = np.array([config.mount_x, config.mount_y, config.mount_height])
    return rotation, -rotation @ centre


def _ground_homography(config: CameraConfig) -> np.ndarray:
    """Ground-to-image homography, sign normalised to ``det < 0`` (see module doc)."""
    if config.homography is not None:
        h = np.array(config.homography, dtype=float).reshape(3, 3)
    else:
        rotation, translation = mounting_extrinsics(config)
        h = intrinsic_matrix(config) @ np.column_stack(
            [rotation[:, 0], rotation[:, 1], translation]
        )
    return -h if np.linalg.det(h) > 0.0 else h


def _dehomogenise(hom: np.ndarray) -> np.ndarray:
    """``(..., 3)`` homogeneous points to ``(..., 2)``; NaN where the last coordinate <= 0."""
    w = hom[..., 2:]
    front = w > 0.0
    return np.where(front, hom[..., :2] / np.where(front, w, 1.0), np.nan)


def _as_points(points: ArrayLike, name: str) -> np.ndarray:
    arr = np.asarray(points, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != 2:
        raise ValueError(f"{name} must have shape (..., 2), got {arr.shape}")
    return arr


class GroundCamera:
    """Pinhole camera viewing the ground plane ``z = 0`` of the robot frame.

    Parameters
    ----------
    config : CameraConfig
        Intrinsics + mounting, or a homography.

    Examples
    --------
    A camera 2 m above the robot origin looking straight down sees a point
    0.5 m ahead ``fy * 0.5 / 2`` pixels above the image centre, one behind
    a horizontal camera nowhere:

    >>> cam = GroundCamera(CameraConfig(mount_x=0.0, mount_height=2.0, mount_pitch=np.pi / 2))
    >>> cam.project([[0.0, 0.0], [0.5, 0.0]]).round(6).tolist()
    [[319.5, 239.5], [319.5, 114.5]]
    >>> GroundCamera(CameraConfig(mount_pitch=0.0)).project([[-1.0, 0.0]]).tolist()
    [[nan, nan]]
    """

    def __init__(self, config: CameraConfig) -> None:
        self.config = config
        self._h = _ground_homography(config)
        self._h_inv = np.linalg.inv(self._h)
        self._h.flags.writeable = False
        h0, h1, h2 = self._h
        self._constraints = np.stack(
            [
                h2,
                h0 + 0.5 * h2,
                (self.width - 0.5) * h2 - h0,
                h1 + 0.5 * h2,
                (self.height - 0.5) * h2 - h1,
            ]
        )
        self._constraints.flags.writeable = False

    @property
    def width(self) -> int:
        """Image width, px."""
        return self.config.width

    @property
    def height(self) -> int:
        """Image height, px."""
        return self.config.height

    @property
    def homography(self) -> np.ndarray:
        """Ground-to-image homography, shape (3, 3), read-only, ``det < 0``."""
        return self._h

    def project(self, points_xy: ArrayLike) -> np.ndarray:
        """Project ground points to pixels.

        Parameters
        ----------
        points_xy : array_like, shape (N, 2)
            Ground points ``(x, y)`` in the robot frame, m (any leading shape).

        Returns
        -------
        ndarray, shape (N, 2)
            ``(u, v)``, px; NaN for points on or behind the camera's image
            plane (depth <= 0). Points in front of the camera but outside the
            image get their (out-of-range) pixel coordinates.
        """
        p = _as_points(points_xy, "points_xy")
        return _dehomogenise(p @ self._h[:, :2].T + self._h[:, 2])

    def backproject(self, uv: ArrayLike) -> np.ndarray:
        """Backproject pixels onto the ground plane.

        Parameters
        ----------
        uv : array_like, shape (N, 2)
            Pixels ``(u, v)``, px (any leading shape).

        Returns
        -------
        ndarray, shape (N, 2)
            ``(x, y)`` on the ground in the robot frame, m; NaN for pixels on
            or above the horizon (their ray never meets the ground ahead).
        """
        q = _as_points(uv, "uv")
        return _dehomogenise(q @ self._h_inv[:, :2].T + self._h_inv[:, 2])

    def image_constraints(self) -> np.ndarray:
        """Return the half-planes of the ground that the image sees.

        Returns
        -------
        ndarray, shape (5, 3)
            Rows ``c``, each a half-plane ``c @ (x, y, 1) >= 0`` of ground
            points (m): row 0 is "in front of the camera" (``c`` is the third
            row of the homography, positive depth), rows 1-4 are the image
            edges ``u >= -0.5``, ``u <= width - 0.5``, ``v >= -0.5``,
            ``v <= height - 0.5`` multiplied by the depth, so linear in
            ``(x, y, 1)``. A ground point with positive depth projects inside
            the image (pixel edges included) if and only if every row is >= 0.
            Read-only (computed once).
        """
        return self._constraints


def footprint_extent(length: ArrayLike, width: ArrayLike, yaw: ArrayLike) -> np.ndarray:
    """Axis-aligned extent of a rotated rectangle (Chen eq. 22).

    ``H_p = B_1 |sin yaw| + W_1 |cos yaw|`` along x and
    ``L_p = B_1 |cos yaw| + W_1 |sin yaw|`` along y.

    Parameters
    ----------
    length, width : array_like
        Rectangle length ``W_1`` (along its own x axis) and width ``B_1``, m.
    yaw : array_like
        Its rotation, rad. All inputs broadcast.

    Returns
    -------
    ndarray, shape (..., 2)
        ``(H_p, L_p)``: extent along x and along y, m.

    Examples
    --------
    >>> footprint_extent(2.0, 1.0, np.pi / 2).round(12).tolist()
    [1.0, 2.0]
    """
    length, width, yaw = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (length, width, yaw))
    )
    c, s = np.abs(np.cos(yaw)), np.abs(np.sin(yaw))
    return np.stack([width * s + length * c, width * c + length * s], axis=-1)


def footprint_corners(pose: ArrayLike, length: float, width: float) -> np.ndarray:
    """Corners of a rectangle centred at ``pose`` and rotated by its yaw.

    Parameters
    ----------
    pose : array_like, shape (3,)
        ``(x, y, yaw)`` of the rectangle's centre, m, m, rad.
    length, width : float
        Extent along the pose's x and y axes, m.

    Returns
    -------
    ndarray, shape (4, 2)
        Front-right, front-left, rear-left, rear-right (counter-clockwise), m.
    """
    x, y, yaw = np.asarray(pose, dtype=float)
    local = 0.5 * np.array([[length, -width], [length, width], [-length, width], [-length, -width]])
    c, s = math.cos(yaw), math.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + np.array([x, y])


def predict_pose(v_l: float, v_r: float, icr_params: ArrayLike, horizon: float) -> np.ndarray:
    """Pose after ``horizon`` seconds at constant track speeds (ICR model).

    The body twist of the ICR model is constant for constant track speeds,
    so one exact arc step from the origin
    (:func:`terrain_odom.kinematics.arc_increment`, what
    :func:`~terrain_odom.kinematics.integrate` adds for one step) gives the
    pose without discretisation error.

    Parameters
    ----------
    v_l, v_r : float
        Track surface speeds, m/s.
    icr_params : array_like, shape (3,) or (4,)
        ``y_l, y_r, x_icr`` (m) and optionally ``alpha`` (e.g. the EKF's
        ``states[k, 3:]``).
    horizon : float
        Prediction time ``t_s``, s.

    Returns
    -------
    ndarray, shape (3,)
        ``(x, y, yaw)`` in the current robot frame, m, m, rad.

    Raises
    ------
    ValueError
        If ``icr_params`` does not hold 3 or 4 values or ``y_l <= y_r``.
    """
    params = np.asarray(icr_params, dtype=float)
    if params.shape not in ((3,), (4,)):
        raise ValueError(f"icr_params must be (y_l, y_r, x_icr[, alpha]), got shape {params.shape}")
    v_x, v_y, omega = twist_icr(v_l, v_r, *params)
    x, y, yaw = arc_increment(v_x, v_y, omega, horizon)  # one step from the origin
    return np.array([x, y, wrap_angle(yaw)])


class RoiStatus(enum.Enum):
    """Where the predicted region falls in the image."""

    INSIDE = "inside"
    """Entirely inside the image."""
    CLIPPED = "clipped"
    """Partly outside the image (or behind the camera); ``box`` is the visible part."""
    OUTSIDE = "outside"
    """Behind the camera or entirely outside the field of view; no box."""
    TOO_SMALL = "too_small"
    """Visible, but its box is narrower or lower than ``min_size``; no box."""


@dataclass(frozen=True, eq=False)
class RoiResult:
    """The predicted region of interest.

    Attributes
    ----------
    status : RoiStatus
    box : tuple of 4 int or None
        ``(x0, y0, x1, y1)``, px, half-open (``image[y0:y1, x0:x1]``),
        clipped to the image; every pixel the visible region overlaps.
        None unless ``status`` is INSIDE or CLIPPED.
    pose : ndarray, shape (3,)
        Predicted pose ``(x, y, yaw)`` in the current robot frame.
    ground_polygon : ndarray, shape (4, 2)
        Corners of the expanded footprint at ``pose`` (current robot frame, m).
    image_polygon : ndarray, shape (M, 2)
        The visible part of that polygon in the image, px (empty if OUTSIDE).
    image_size : tuple of int
        ``(width, height)`` of the camera image, px.
    reason : str
        Why the region is not (entirely) usable; empty when INSIDE.
    """

    status: RoiStatus
    box: tuple[int, int, int, int] | None
    pose: np.ndarray
    ground_polygon: np.ndarray
    image_polygon: np.ndarray
    image_size: tuple[int, int]
    reason: str

    @property
    def ahead(self) -> float:
        """Distance from the robot to the region's centre (the predicted pose), m."""
        return float(np.hypot(self.pose[0], self.pose[1]))


def _clip_half_plane(polygon: np.ndarray, coeffs: np.ndarray) -> np.ndarray:
    """Part of a convex polygon (K, 2) where ``coeffs @ (x, y, 1) >= 0`` (Sutherland-Hodgman)."""
    side = (polygon @ coeffs[:2] + coeffs[2]).tolist()
    if min(side, default=0.0) >= 0.0:  # wholly inside: the polygon itself
        return polygon
    points = polygon.tolist()  # Python floats: the same arithmetic per coordinate, less overhead
    out = []
    for i, ((x, y), s_i) in enumerate(zip(points, side, strict=True)):
        j = (i + 1) % len(points)
        if s_i >= 0.0:
            out.append((x, y))
        if (s_i >= 0.0) != (side[j] >= 0.0):
            t = s_i / (s_i - side[j])
            out.append((x + (points[j][0] - x) * t, y + (points[j][1] - y) * t))
    return np.array(out, dtype=float).reshape(-1, 2)


def _pixel_box(uv: np.ndarray, width: int, height: int) -> tuple[int, int, int, int]:
    """Half-open box of the pixels overlapped by points ``uv`` (M, 2), clipped to the image."""
    u, v = uv.T.tolist()  # Python floats: the same arithmetic, less overhead
    x0, x1 = math.floor(min(u) + 0.5), math.ceil(max(u) + 0.5)
    y0, y1 = math.floor(min(v) + 0.5), math.ceil(max(v) + 0.5)
    return _clamp(x0, width), _clamp(y0, height), _clamp(x1, width), _clamp(y1, height)


def _clamp(value: int, size: int) -> int:
    """``value`` clipped to ``0 .. size``."""
    return min(max(value, 0), size)


def _visible_pixels(camera: GroundCamera, ground: np.ndarray) -> np.ndarray | None:
    """Pixels of the vertices of the part of a convex ground polygon seen in the image.

    Returns
    -------
    ndarray, shape (M, 2), or None
        px (``M = 0``: in front of the camera but outside the image); None if
        the polygon is entirely behind the camera.
    """
    constraints = camera.image_constraints()
    visible = _clip_half_plane(ground, constraints[0])
    if len(visible) == 0:
        return None
    for coeffs in constraints[1:]:
        visible = _clip_half_plane(visible, coeffs)
    uv = camera.project(visible)
    return uv[np.isfinite(uv).all(axis=1)]


def _fully_visible(camera: GroundCamera, ground: np.ndarray) -> bool:
    """Whether every vertex of a convex ground polygon (K, 2) is in front and inside the image."""
    values = np.column_stack((ground, np.ones(len(ground)))) @ camera.image_constraints().T
    return bool(np.all(values >= 0.0) and np.all(values[:, 0] > 0.0))


def region_of_interest(
    camera: GroundCamera,
    roi: RoiConfig,
    v_l: float,
    v_r: float,
    icr_params: ArrayLike,
) -> RoiResult:
    """Image region the robot's expanded footprint will cover ``roi.horizon`` s ahead.

    The pose is predicted with :func:`predict_pose`; the footprint expanded
    by ``roi.expand`` (``W_1, B_1`` of Chen eq. 22) is placed there and
    clipped exactly, in the ground plane, to the part the camera sees (in
    front of it and inside the image: each image edge is a half-plane of the
    ground). A homography maps that convex polygon to a convex polygon, so
    the bounding box of its projected vertices is the region's box.

    Parameters
    ----------
    camera : GroundCamera
    roi : RoiConfig
    v_l, v_r : float
        Current track surface speeds, m/s, held over the horizon.
    icr_params : array_like, shape (3,) or (4,)
        Current kinematic model ``y_l, y_r, x_icr[, alpha]``.

    Returns
    -------
    RoiResult
        Never falls back to the full frame: a region behind the camera or
        outside the image is OUTSIDE with no box, one too small for
        ``roi.min_size`` is TOO_SMALL with no box.
    """
    pose = predict_pose(v_l, v_r, icr_params, roi.horizon)
    ground = footprint_corners(
        pose, roi.expand * roi.footprint_length, roi.expand * roi.footprint_width
    )

    def result(
        status: RoiStatus, box: tuple[int, int, int, int] | None, uv: np.ndarray, reason: str
    ) -> RoiResult:
        return RoiResult(status, box, pose, ground, uv, (camera.width, camera.height), reason)

    uv = _visible_pixels(camera, ground)
    if uv is None or len(uv) == 0:
        reason = "behind the camera" if uv is None else "outside the image"
        return result(RoiStatus.OUTSIDE, None, np.empty((0, 2)), reason)
    box = _pixel_box(uv, camera.width, camera.height)
    box_w, box_h = box[2] - box[0], box[3] - box[1]
    if min(box_w, box_h) < roi.min_size:
        reason = f"visible part {box_w}x{box_h} px is smaller than min_size={roi.min_size} px"
        return result(RoiStatus.TOO_SMALL, None, uv, reason)
    if _fully_visible(camera, ground):
        return result(RoiStatus.INSIDE, box, uv, "")
    return result(RoiStatus.CLIPPED, box, uv, "partly behind the camera or outside the image")


def crop(image: np.ndarray, roi_result: RoiResult) -> np.ndarray:
    """Return the region of interest of an image, as a view.

    Parameters
    ----------
    image : ndarray, shape (height, width) or (height, width, C)
        A frame of the camera the result was computed for.
    roi_result : RoiResult

    Returns
    -------
    ndarray, shape (y1 - y0, x1 - x0[, C])
        ``image[y0:y1, x0:x1]`` (a view, not a copy).

    Raises
    ------
    ValueError
        If the result has no box (OUTSIDE or TOO_SMALL: the message says why)
        or the image size differs from the camera's.
    """
    if roi_result.box is None:
        raise ValueError(
            f"no region of interest to crop: {roi_result.status.name} ({roi_result.reason})"
        )
    width, height = roi_result.image_size
    if image.shape[:2] != (height, width):
        raise ValueError(
            f"image is {image.shape[1]}x{image.shape[0]} px but the camera's is {width}x{height}"
        )
    x0, y0, x1, y1 = roi_result.box
    return image[y0:y1, x0:x1]

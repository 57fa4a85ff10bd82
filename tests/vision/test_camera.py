"""Tests of the ground-plane camera model and the predicted region of interest."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from terrain_odom.config import NON_NEGATIVE, SIGNED, CameraConfig, RoiConfig, build_section
from terrain_odom.errors import ConfigError
from terrain_odom.vision.camera import (
    GroundCamera,
    RoiResult,
    RoiStatus,
    crop,
    footprint_corners,
    footprint_extent,
    intrinsic_matrix,
    mounting_extrinsics,
    predict_pose,
    region_of_interest,
)

IDD = (0.3, -0.3, 0.0, 1.0)  # y_l, y_r, x_icr, alpha: ideal differential drive, B = 0.6 m

MOUNTINGS = [
    CameraConfig(),
    CameraConfig(mount_x=0.3, mount_height=1.0, mount_pitch=math.radians(35)),
    CameraConfig(mount_x=-0.1, mount_y=0.2, mount_pitch=1.2, mount_yaw=0.4, fx=420.0, fy=380.0),
    CameraConfig(mount_pitch=0.05, mount_yaw=-2.5, cx=300.0, cy=200.0, mount_height=1.7),
    CameraConfig(mount_pitch=math.pi / 2, mount_x=0.0, mount_height=2.0),
]

# A camera 1 m high looking 35 deg down sees the ground from ~0.9 m to ~6.4 m ahead.
FAR_CAMERA = CameraConfig(mount_x=0.3, mount_height=1.0, mount_pitch=math.radians(35))


def _ground_grid(extent: float = 8.0, n: int = 41) -> np.ndarray:
    x, y = np.meshgrid(np.linspace(-extent, extent, n), np.linspace(-extent, extent, n))
    return np.stack([x.ravel(), y.ravel()], axis=-1)


def _depth(config: CameraConfig, points_xy: np.ndarray) -> np.ndarray:
    """Depth of ground points along the optical axis, from the mounting alone."""
    rotation, translation = mounting_extrinsics(config)
    points = np.c_[points_xy, np.zeros(len(points_xy))]
    return (points @ rotation.T + translation)[:, 2]


# --- configuration --------------------------------------------------------------------------


def test_field_metadata_is_that_of_the_config_module():
    for cls in (CameraConfig, RoiConfig):
        for f in dataclasses.fields(cls):
            assert dict(f.metadata) in ({}, SIGNED, NON_NEGATIVE), f.name
    signed = {f.name for f in dataclasses.fields(CameraConfig) if f.metadata == SIGNED}
    assert signed == {"mount_x", "mount_y", "mount_pitch", "mount_yaw", "homography"}


def test_build_section_accepts_valid_camera_and_roi_sections():
    cam = build_section(
        CameraConfig(),
        {
            "width": 320,
            "mount_y": -0.1,
            "mount_pitch": 0.0,
            "homography": [1, 0, 0, 0, 1, 0, 0, 0, 1],
        },
        "camera",
    )
    assert (cam.width, cam.mount_y, cam.mount_pitch) == (320, -0.1, 0.0)
    assert cam.homography == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    assert build_section(RoiConfig(), {"horizon": 0, "min_size": 16}, "roi") == RoiConfig(
        horizon=0.0, min_size=16
    )


@pytest.mark.parametrize(
    ("section", "data", "message"),
    [
        (CameraConfig(), {"mount_height": -0.5}, r"camera\.mount_height: must be > 0"),
        (CameraConfig(), {"fx": 0}, r"camera\.fx: must be > 0"),
        (CameraConfig(), {"width": 0}, r"camera\.width: must be a whole number >= 1"),
        (CameraConfig(), {"mount_pitch": 2.0}, r"mount_pitch: must be in \(-pi/2, pi/2\]"),
        (CameraConfig(), {"mount_yaw": 4.0}, r"mount_yaw: must be in \[-pi, pi\]"),
        (CameraConfig(), {"homography": [1, 0, 0, 0, 1, 0, 0, 0]}, r"homography: must hold 9"),
        (CameraConfig(), {"homography": [1, 2, 3, 2, 4, 6, 0, 0, 1]}, r"homography: .*singular"),
        (CameraConfig(), {"homography": [1, 0, "a"]}, r"camera\.homography\[2\]: must be a number"),
        (RoiConfig(), {"horizon": -1.0}, r"roi\.horizon: must be >= 0"),
        (RoiConfig(), {"expand": 0.0}, r"roi\.expand: must be > 0"),
        (RoiConfig(), {"min_size": 0}, r"roi\.min_size: must be a whole number >= 1"),
    ],
)
def test_build_section_rejects_invalid_values(section, data, message):
    where = "camera" if isinstance(section, CameraConfig) else "roi"
    with pytest.raises(ConfigError, match=message):
        build_section(section, data, where)


# --- hand-worked projections ----------------------------------------------------------------


def test_straight_down_camera_hand_worked():
    # Optical axis -z; image right = robot right (-y), image up (-v) = robot forward (+x).
    cfg = CameraConfig(
        fx=400.0, fy=600.0, mount_x=0.2, mount_y=0.1, mount_height=0.5, mount_pitch=math.pi / 2
    )
    cam = GroundCamera(cfg)
    d = 0.25
    points = [[0.2, 0.1], [0.2 + d, 0.1], [0.2, 0.1 + d], [0.2 - d, 0.1 - d]]
    expected = [
        [cfg.cx, cfg.cy],
        [cfg.cx, cfg.cy - cfg.fy * d / 0.5],  # forward: up the image
        [cfg.cx - cfg.fx * d / 0.5, cfg.cy],  # left: left in the image
        [cfg.cx + cfg.fx * d / 0.5, cfg.cy + cfg.fy * d / 0.5],
    ]
    np.testing.assert_allclose(cam.project(points), expected, atol=1e-9)


def test_horizontal_camera_hand_worked():
    # Pitch 0: the horizon is the row v = cy; the ground is below it.
    cfg = CameraConfig(mount_x=0.2, mount_y=0.0, mount_height=0.5, mount_pitch=0.0)
    cam = GroundCamera(cfg)
    d, e = 2.0, 0.4  # 2 m ahead of the camera, 0.4 m to its left
    uv = cam.project([[0.2 + d, 0.0], [0.2 + d, e]])
    np.testing.assert_allclose(
        uv,
        [[cfg.cx, cfg.cy + cfg.fy * 0.5 / d], [cfg.cx - cfg.fx * e / d, cfg.cy + cfg.fy * 0.5 / d]],
    )
    # Behind the camera and in its image plane: no pixel.
    assert np.isnan(cam.project([[0.1, 0.0], [0.2, 3.0], [-5.0, -1.0]])).all()
    # Backprojection: NaN on and above the horizon, the ground point below it.
    ground = cam.backproject([[cfg.cx, cfg.cy - 10.0], [100.0, cfg.cy], [cfg.cx, cfg.cy + 125.0]])
    assert np.isnan(ground[:2]).all()
    np.testing.assert_allclose(ground[2], [0.2 + cfg.fy * 0.5 / 125.0, 0.0], atol=1e-12)


@pytest.mark.parametrize(
    ("pitch", "yaw"), [(0.3, 0.0), (math.radians(45), 0.0), (1.0, math.pi / 2)]
)
def test_optical_axis_meets_the_ground_at_height_over_tan_pitch(pitch, yaw):
    cfg = CameraConfig(
        mount_x=0.2, mount_y=-0.1, mount_height=0.8, mount_pitch=pitch, mount_yaw=yaw
    )
    reach = 0.8 / math.tan(pitch)
    point = [0.2 + reach * math.cos(yaw), -0.1 + reach * math.sin(yaw)]
    np.testing.assert_allclose(GroundCamera(cfg).project([point]), [[cfg.cx, cfg.cy]], atol=1e-9)


def test_homography_sign_gives_positive_depth_and_det_is_minus_fx_fy_h():
    for cfg in MOUNTINGS:
        h = GroundCamera(cfg).homography
        assert np.linalg.det(h) == pytest.approx(-cfg.fx * cfg.fy * cfg.mount_height)
        pts = _ground_grid()
        np.testing.assert_allclose(
            np.c_[pts, np.ones(len(pts))] @ h[2], _depth(cfg, pts), atol=1e-12
        )


def test_project_accepts_any_leading_shape_and_rejects_other_shapes():
    cam = GroundCamera(CameraConfig())
    assert cam.project([1.0, 0.0]).shape == (2,)
    assert cam.backproject(np.zeros((2, 3, 2))).shape == (2, 3, 2)
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 2\)"):
        cam.project([[1.0, 0.0, 0.0]])


# --- the two parametrisations, OpenCV, round trips --------------------------------------------


@pytest.mark.parametrize("cfg", MOUNTINGS)
def test_homography_parametrisation_equals_mounting(cfg):
    mounted = GroundCamera(cfg)
    as_h = CameraConfig(
        fx=1.0, fy=2.0, mount_pitch=0.1, homography=tuple(mounted.homography.ravel())
    )
    given = GroundCamera(as_h)
    pts = _ground_grid()
    pix = (
        np.array(np.meshgrid(np.arange(-50.0, 700.0, 25.0), np.arange(-50.0, 530.0, 25.0)))
        .reshape(2, -1)
        .T
    )
    np.testing.assert_array_equal(given.homography, mounted.homography)
    np.testing.assert_array_equal(given.project(pts), mounted.project(pts))
    np.testing.assert_array_equal(given.backproject(pix), mounted.backproject(pix))
    # Any scale, negative included, is the same camera.
    flipped = GroundCamera(
        dataclasses.replace(as_h, homography=tuple(-2.5 * mounted.homography.ravel()))
    )
    np.testing.assert_allclose(flipped.project(pts), mounted.project(pts), rtol=1e-9)
    np.testing.assert_allclose(
        flipped.backproject(pix), mounted.backproject(pix), rtol=1e-9, atol=1e-12
    )


@pytest.mark.parametrize("cfg", MOUNTINGS)
def test_projection_agrees_with_cv2_project_points(cfg):
    rotation, translation = mounting_extrinsics(cfg)
    rvec, _ = cv2.Rodrigues(rotation)
    pts = _ground_grid()
    depth = _depth(cfg, pts)
    in_front = depth > 1e-3  # OpenCV also "projects" points behind the camera
    obj = np.c_[pts[in_front], np.zeros(in_front.sum())]
    expected, _ = cv2.projectPoints(obj, rvec, translation, intrinsic_matrix(cfg), np.zeros(5))
    uv = GroundCamera(cfg).project(pts)
    np.testing.assert_allclose(uv[in_front], expected.reshape(-1, 2), rtol=1e-9, atol=1e-6)
    assert np.isnan(uv[depth < -1e-9]).all() and np.isfinite(uv[depth > 1e-9]).all()


def test_rotation_is_proper_and_forward_camera_is_upright():
    for cfg in MOUNTINGS:
        rotation, _ = mounting_extrinsics(cfg)
        np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(rotation) == pytest.approx(1.0)
    rotation, translation = mounting_extrinsics(CameraConfig(mount_pitch=0.0, mount_x=0.2))
    # camera x = robot right, camera y = robot down, camera z = robot forward
    np.testing.assert_allclose(rotation, [[0, -1, 0], [0, 0, -1], [1, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(translation, [0.0, 0.5, -0.2], atol=1e-15)


@pytest.mark.parametrize("cfg", MOUNTINGS)
def test_backprojection_round_trip(cfg):
    cam = GroundCamera(cfg)
    rng = np.random.default_rng(3)
    pix = rng.uniform([0, 0], [cfg.width - 1, cfg.height - 1], size=(500, 2))
    ground = cam.backproject(pix)
    below_horizon = ~np.isnan(ground[:, 0])
    assert below_horizon.sum() > 100
    np.testing.assert_allclose(cam.project(ground[below_horizon]), pix[below_horizon], atol=1e-7)
    pts = rng.uniform(-6, 6, size=(500, 2))
    in_front = _depth(cfg, pts) > 1e-2
    np.testing.assert_allclose(
        cam.backproject(cam.project(pts[in_front])), pts[in_front], atol=1e-9
    )


# --- footprint and prediction ----------------------------------------------------------------


def test_eq22_extent_matches_the_bounds_of_the_rotated_corners():
    for yaw in np.linspace(-math.pi, math.pi, 37):
        corners = footprint_corners([1.0, -2.0, yaw], 0.72, 0.6)
        extent = footprint_extent(0.72, 0.6, yaw)
        np.testing.assert_allclose(extent, corners.max(axis=0) - corners.min(axis=0), atol=1e-12)
        np.testing.assert_allclose(corners.mean(axis=0), [1.0, -2.0], atol=1e-12)
    assert footprint_extent([0.72, 1.0], 0.6, [0.0, math.pi / 2]).shape == (2, 2)


def test_footprint_corners_are_counter_clockwise_from_front_right():
    corners = footprint_corners([0.0, 0.0, math.pi / 2], 2.0, 1.0)
    # Facing +y: the front-right corner is at (+0.5, +1).
    np.testing.assert_allclose(
        corners, [[0.5, 1.0], [-0.5, 1.0], [-0.5, -1.0], [0.5, -1.0]], atol=1e-12
    )


def test_predicted_pose_is_the_exact_arc():
    # v = 1 m/s, omega = 2 rad/s for 0.5 s: an arc of 1 rad on a 0.5-m circle.
    pose = predict_pose(0.5, 1.5, (0.25, -0.25, 0.0), 0.5)
    np.testing.assert_allclose(
        pose, [0.5 * math.sin(1.0), 0.5 * (1 - math.cos(1.0)), 1.0], atol=1e-12
    )
    # alpha = 0.5 halves the speeds; x_icr = 0.2 adds v_y = -omega * x_icr.
    np.testing.assert_allclose(predict_pose(1.0, 1.0, (0.3, -0.3, 0.2, 0.5), 2.0), [1.0, 0.0, 0.0])
    np.testing.assert_allclose(predict_pose(0.0, 0.0, IDD, 5.0), [0.0, 0.0, 0.0])
    # Turning on the spot with x_icr = 0.2: the origin rotates 1 rad about (0.2, 0).
    spin = predict_pose(-0.3, 0.3, (0.3, -0.3, 0.2), 1.0)
    np.testing.assert_allclose(
        spin, [0.2 - 0.2 * math.cos(1.0), -0.2 * math.sin(1.0), 1.0], atol=1e-12
    )
    with pytest.raises(ValueError, match="icr_params"):
        predict_pose(1.0, 1.0, (0.3, -0.3), 1.0)
    with pytest.raises(ValueError, match="y_l > y_r"):
        predict_pose(1.0, 1.0, (-0.3, 0.3, 0.0), 1.0)


# --- region of interest ----------------------------------------------------------------------


def _box_centre(box: tuple[int, int, int, int]) -> tuple[float, float]:
    return 0.5 * (box[0] + box[2]), 0.5 * (box[1] + box[3])


def test_degenerate_zero_speed_gives_the_footprint_at_the_current_pose():
    # Straight-down camera 2 m above the origin: 250 px per metre; exact binary fractions.
    cam = GroundCamera(CameraConfig(mount_x=0.0, mount_height=2.0, mount_pitch=math.pi / 2))
    roi = RoiConfig(horizon=3.0, footprint_length=0.5, footprint_width=0.25, expand=1.25)
    res = region_of_interest(cam, roi, 0.0, 0.0, IDD)
    assert res.status is RoiStatus.INSIDE and res.reason == ""
    np.testing.assert_array_equal(res.pose, [0.0, 0.0, 0.0])
    np.testing.assert_allclose(
        res.ground_polygon,
        [[0.3125, -0.15625], [0.3125, 0.15625], [-0.3125, 0.15625], [-0.3125, -0.15625]],
    )
    # u in 319.5 -+ 250 * 0.15625 = [280.4375, 358.5625] -> pixels 280..359;
    # v in 239.5 -+ 250 * 0.3125  = [161.375, 317.625]   -> pixels 161..318.
    assert res.box == (280, 161, 360, 319)
    image = np.zeros((480, 640, 3), np.uint8)
    patch = crop(image, res)
    assert patch.shape == (158, 80, 3) and np.shares_memory(patch, image)


@pytest.mark.parametrize(
    ("offset_px", "status"), [(-0.1, RoiStatus.INSIDE), (0.1, RoiStatus.CLIPPED)]
)
def test_the_image_ends_at_the_outer_edge_of_its_last_pixel(offset_px, status):
    # Straight down, 250 px/m, camera shifted left so the footprint's right side
    # (y = -0.15625) projects to u = 319.5 + 250 * (0.15625 + mount_y) = 639.5 + offset_px.
    mount_y = (320.0 + offset_px) / 250.0 - 0.15625
    cfg = CameraConfig(mount_x=0.0, mount_y=mount_y, mount_height=2.0, mount_pitch=math.pi / 2)
    roi = RoiConfig(footprint_length=0.5, footprint_width=0.25, expand=1.25)
    res = region_of_interest(GroundCamera(cfg), roi, 0.0, 0.0, IDD)
    assert res.status is status and res.box[2] == 640


def test_box_of_an_inside_region_is_that_of_its_projected_corners():
    cam = GroundCamera(FAR_CAMERA)
    res = region_of_interest(cam, RoiConfig(horizon=2.0), 0.9, 1.1, IDD)
    assert res.status is RoiStatus.INSIDE
    uv = cam.project(res.ground_polygon)
    lo, hi = np.floor(uv.min(axis=0) + 0.5), np.ceil(uv.max(axis=0) + 0.5)
    assert res.box == (lo[0], lo[1], hi[0], hi[1])
    np.testing.assert_allclose(np.sort(res.image_polygon, axis=0), np.sort(uv, axis=0))


def test_straight_driving_moves_the_region_up_the_image_as_the_horizon_grows():
    cam = GroundCamera(FAR_CAMERA)
    boxes = [region_of_interest(cam, RoiConfig(horizon=t), 1.0, 1.0, IDD) for t in (2.0, 3.0, 4.0)]
    assert all(b.status is RoiStatus.INSIDE for b in boxes)
    v0, v1 = [[b.box[1] for b in boxes], [b.box[3] for b in boxes]]
    assert v0[0] > v0[1] > v0[2] and v1[0] > v1[1] > v1[2]
    # Farther is smaller, and centred on the principal column (camera on the axis).
    widths = [b.box[2] - b.box[0] for b in boxes]
    assert widths[0] > widths[1] > widths[2]
    for b in boxes:
        assert _box_centre(b.box)[0] == pytest.approx(FAR_CAMERA.cx, abs=1.0)


def test_turning_shifts_the_region_towards_the_turn():
    cam = GroundCamera(FAR_CAMERA)
    roi = RoiConfig(horizon=2.0)
    straight = region_of_interest(cam, roi, 1.0, 1.0, IDD)
    left = region_of_interest(cam, roi, 0.9, 1.1, IDD)
    right = region_of_interest(cam, roi, 1.1, 0.9, IDD)
    assert left.pose[1] > 0 and left.pose[2] > 0
    assert _box_centre(left.box)[0] < _box_centre(straight.box)[0] - 20
    assert _box_centre(right.box)[0] > _box_centre(straight.box)[0] + 20
    # Mirror images about the principal column.
    assert _box_centre(left.box)[0] + _box_centre(right.box)[0] == pytest.approx(
        2 * FAR_CAMERA.cx, abs=1.0
    )


def test_region_behind_the_camera_is_outside():
    res = region_of_interest(GroundCamera(CameraConfig()), RoiConfig(horizon=2.0), -1.0, -1.0, IDD)
    assert res.status is RoiStatus.OUTSIDE and res.box is None
    assert "behind the camera" in res.reason
    assert res.image_polygon.shape == (0, 2)
    np.testing.assert_allclose(res.pose, [-2.0, 0.0, 0.0])


def test_a_horizon_so_long_the_region_leaves_the_image_is_outside():
    # The default camera (45 deg down) sees the ground up to ~1.6 m ahead only.
    cam = GroundCamera(CameraConfig())
    assert region_of_interest(cam, RoiConfig(horizon=1.0), 1.0, 1.0, IDD).status is RoiStatus.INSIDE
    res = region_of_interest(cam, RoiConfig(horizon=5.0), 1.0, 1.0, IDD)
    assert res.status is RoiStatus.OUTSIDE and res.box is None
    assert res.reason == "outside the image"
    with pytest.raises(ValueError, match="OUTSIDE.*outside the image"):
        crop(np.zeros((480, 640)), res)


def test_far_region_below_a_visible_horizon_is_too_small():
    cam = GroundCamera(CameraConfig(mount_pitch=0.0))
    res = region_of_interest(cam, RoiConfig(horizon=20.0), 1.0, 1.0, IDD)
    assert res.status is RoiStatus.TOO_SMALL and res.box is None
    assert "min_size=8" in res.reason and len(res.image_polygon) == 4
    loose = region_of_interest(cam, RoiConfig(horizon=20.0, min_size=1), 1.0, 1.0, IDD)
    assert loose.status is RoiStatus.INSIDE and loose.box[3] - loose.box[1] < 8


def _assert_box_matches_pixel_centres(cam: GroundCamera, res: RoiResult) -> None:
    """Assert the box holds the pixels whose centres see the ground polygon, +1 px at most."""
    u, v = np.meshgrid(np.arange(cam.width, dtype=float), np.arange(cam.height, dtype=float))
    ground = cam.backproject(np.stack([u.ravel(), v.ravel()], axis=-1))
    corners = res.ground_polygon  # counter-clockwise
    edges = np.roll(corners, -1, axis=0) - corners
    rel = ground[:, None, :] - corners[None]
    cross = edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0]
    seen = np.all(cross >= 0.0, axis=1)  # False for NaN (above the horizon)
    cols, rows = u.ravel()[seen], v.ravel()[seen]
    centres = (cols.min(), rows.min(), cols.max() + 1, rows.max() + 1)
    x0, y0, x1, y1 = res.box
    assert x0 <= centres[0] <= x0 + 1 and y0 <= centres[1] <= y0 + 1, (res.box, centres)
    assert x1 - 1 <= centres[2] <= x1 and y1 - 1 <= centres[3] <= y1, (res.box, centres)


@pytest.mark.parametrize(
    ("cfg", "horizon", "v_l", "v_r", "edge"),
    [
        (FAR_CAMERA, 1.0, 1.0, 1.0, "bottom"),
        (CameraConfig(), 1.5, 1.0, 1.0, "top"),
        (FAR_CAMERA, 3.0, 0.9, 1.1, "left"),
    ],
)
def test_region_straddling_an_image_edge_is_clipped_to_the_visible_part(
    cfg, horizon, v_l, v_r, edge
):
    cam = GroundCamera(cfg)
    res = region_of_interest(cam, RoiConfig(horizon=horizon), v_l, v_r, IDD)
    assert res.status is RoiStatus.CLIPPED
    x0, y0, x1, y1 = res.box
    assert {"bottom": y1 == cam.height, "top": y0 == 0, "left": x0 == 0}[edge]
    # The exact clip agrees with the pixels whose rays hit the footprint.
    _assert_box_matches_pixel_centres(cam, res)
    assert crop(np.zeros((480, 640)), res).shape == (y1 - y0, x1 - x0)


def test_region_partly_behind_the_camera_is_clipped_not_lost():
    # A low camera at the front of the robot: the current (long) footprint
    # reaches behind the camera's image plane; its visible part is still found.
    cam = GroundCamera(CameraConfig(mount_x=0.2, mount_height=0.3, mount_pitch=0.6))
    res = region_of_interest(cam, RoiConfig(horizon=0.0, footprint_length=2.0), 0.0, 0.0, IDD)
    assert res.status is RoiStatus.CLIPPED
    assert np.isnan(cam.project(res.ground_polygon)).any()
    _assert_box_matches_pixel_centres(cam, res)


def test_crop_rejects_an_image_of_another_size():
    cam = GroundCamera(FAR_CAMERA)
    res = region_of_interest(cam, RoiConfig(horizon=2.0), 1.0, 1.0, IDD)
    with pytest.raises(ValueError, match="image is 320x240 px but the camera's is 640x480"):
        crop(np.zeros((240, 320)), res)

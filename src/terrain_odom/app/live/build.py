"""The live odometry of a configuration file: geometry overrides, checks, classifier, warm-up."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from terrain_odom.app.calibration import check_heading_bias
from terrain_odom.app.live.odometry import LiveOdometry
from terrain_odom.app.live.options import LiveOptions, LiveTopics
from terrain_odom.app.live.output import twist_with_covariance
from terrain_odom.config import Config, load_config
from terrain_odom.errors import ConfigError
from terrain_odom.estimation._kernel_switch import compile_kernels
from terrain_odom.estimation.online import OnlineOdometry

if TYPE_CHECKING:
    from terrain_odom.vision.frame_classifier import FrameClassifier

__all__ = ["build_live"]


def build_live(
    config_path: str | Path | None,
    topics: LiveTopics,
    options: LiveOptions | None = None,
    *,
    classifier_path: str | Path | None = None,
    estimator: str = "icr-ekf",
    robot: dict[str, float | None] | None = None,
    **callbacks: Any,
) -> LiveOdometry:
    """Build the live odometry of a configuration file (the built-in defaults for None).

    ``classifier_path``: a terrain classifier file for the ``images`` role's
    frames (the packaged default model when ``topics.images`` is given
    without one); ``robot``: ``track_width``, ``wheel_radius`` overriding the
    configuration's (``import``'s ``--track-width``, ``--wheel-radius``);
    ``callbacks``: the keyword arguments of :class:`LiveOdometry`.

    Raises
    ------
    ConfigError, InputFileError
        A bad configuration, options, or classifier file (one line).
    """
    config = load_config(config_path)
    given = {k: v for k, v in (robot or {}).items() if v is not None}
    for name, value in given.items():
        if not 0.0 < value < math.inf:
            raise ConfigError(f"--{name.replace('_', '-')} must be finite and > 0 m, got {value}")
    if given:
        config = dataclasses.replace(config, robot=dataclasses.replace(config.robot, **given))
    if topics.stamps not in ("header", "receive"):
        raise ConfigError(f"--stamps must be header or receive, got {topics.stamps!r}")
    check_heading_bias(config, topics.pose is not None, "no --pose-topic")
    frames = None
    if topics.images is not None:
        from terrain_odom.io.classifier_file import default_classifier, load_classifier
        from terrain_odom.vision.camera import GroundCamera
        from terrain_odom.vision.frame_classifier import FrameClassifier

        path = classifier_path if classifier_path is not None else default_classifier()
        frames = FrameClassifier(load_classifier(path), GroundCamera(config.camera), config.roi)
    odometry = OnlineOdometry(config, estimator=estimator)  # type: ignore[arg-type]
    _warm_up(config, estimator, frames)
    return LiveOdometry(odometry, topics, options, frame_classifier=frames, **callbacks)


def _warm_up(config: Config, estimator: str, frames: FrameClassifier | None) -> None:
    """Make the first calls now: numba's kernels (~1.5 s, holding the GIL), lazy imports.

    Else they fall on the first messages (or, compiled after a number of
    calls, on the Nth), stalling the wheels.
    """
    compile_kernels()
    warm = OnlineOdometry(config, estimator=estimator)  # type: ignore[arg-type]
    for k in range(4):
        warm.wheels(0.02 * k, 0.5, 0.6)
        warm.pose(0.02 * k, 0.01 * k, 0.0, 0.0)
    state, std = warm.estimate()
    twist_with_covariance(0.5, 0.6, warm.names, state, std)
    if frames is not None:
        camera = frames.camera
        noise = np.random.default_rng(0).integers(0, 256, (camera.height, camera.width, 3))
        params = [state[warm.names.index(n)] for n in ("y_l", "y_r", "x_icr")]
        frames.classify(0.0, noise.astype(np.uint8), 0.5, 0.6, np.array(params))

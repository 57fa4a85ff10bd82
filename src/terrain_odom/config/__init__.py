"""Typed configuration: every section a frozen dataclass, loaded from YAML and validated.

The defaults of the dataclasses are the values in ``config/default.yaml``
(a test keeps the two equal). Noise values are standard deviations:
``sigma_p0``, ``sigma_pb`` and ``sigma_prior`` in the state's units,
``sigma_r`` in the measurement's units, and ``sigma_q`` as continuous-time
noise densities in units per square-root second (the discrete process noise
over a step of ``dt`` seconds is ``sigma_q**2 * dt``).
"""

from __future__ import annotations

from terrain_odom.config.camera import CameraConfig, RoiConfig
from terrain_odom.config.classifier import (
    PAPER_K,
    ClassifierConfig,
    load_classifier_config,
    paper_config,
)
from terrain_odom.config.fields import NON_NEGATIVE, SIGNED, build_section
from terrain_odom.config.loader import config_to_dict, load_config, with_pose_delay
from terrain_odom.config.sections import (
    FORMAT_VERSION,
    MAX_POSE_DELAY,
    Config,
    EkfConfig,
    EvaluationConfig,
    IcrLimits,
    IcrSigmas,
    IcrState,
    PoseChangeSigmas,
    PoseIcrSigmas,
    PoseSigmas,
    RobotConfig,
    SlipEkfConfig,
    SlipParams,
    SlipSigmas,
    TerrainConfig,
    TimeConfig,
)

__all__ = [
    "FORMAT_VERSION",
    "MAX_POSE_DELAY",
    "SIGNED",
    "NON_NEGATIVE",
    "build_section",
    "CameraConfig",
    "RoiConfig",
    "RobotConfig",
    "IcrState",
    "PoseIcrSigmas",
    "PoseSigmas",
    "IcrSigmas",
    "IcrLimits",
    "EkfConfig",
    "TerrainConfig",
    "EvaluationConfig",
    "SlipParams",
    "SlipSigmas",
    "PoseChangeSigmas",
    "SlipEkfConfig",
    "TimeConfig",
    "Config",
    "ClassifierConfig",
    "PAPER_K",
    "paper_config",
    "load_classifier_config",
    "load_config",
    "config_to_dict",
    "with_pose_delay",
]

"""What the live odometry is told: the topics of each role and the ordering policy's options."""

from __future__ import annotations

import math
from dataclasses import dataclass

from terrain_odom.errors import ConfigError

__all__ = ["FRAME_POLICIES", "ROLES", "LiveOptions", "LiveTopics"]

FRAME_POLICIES = ("async", "sync")
ROLES = ("wheels", "pose", "heading", "images")


@dataclass(frozen=True)
class LiveTopics:
    """Where the messages of each role come from and how to read them (``import``'s options).

    ``wheels`` is required; a role without a topic (None) is not listened to.
    """

    wheels: str
    pose: str | None = None
    heading: str | None = None
    images: str | None = None
    left_joints: tuple[str, ...] = ("*left*",)
    right_joints: tuple[str, ...] = ("*right*",)
    pose_frames: tuple[str, str] | None = None
    gps_origin: tuple[float, float, float] | None = None
    stamps: str = "header"


@dataclass(frozen=True)
class LiveOptions:
    """The ordering policy (:mod:`terrain_odom.app.live.odometry`).

    Attributes
    ----------
    delay : float
        s: how long a message waits for earlier-stamped ones (stamp time).
    max_gap : float
        s: a longer gap between wheel messages starts a new segment.
    jump_back : float
        s: a wheel message this much before the latest row restarts the clock.
    frames : {"async", "sync"}
        Classify frames off the wheel path (default), or wait for each.
    idle : float
        s of wall time without a message after which
        :meth:`~terrain_odom.app.live.odometry.LiveOdometry.poll` releases
        what is buffered (a paused stream's last messages).
    """

    delay: float = 0.1
    max_gap: float = 0.5
    jump_back: float = 1.0
    frames: str = "async"
    idle: float = 0.25

    def __post_init__(self) -> None:
        for name in ("delay", "max_gap", "jump_back", "idle"):
            value = getattr(self, name)
            bound = ">=" if name == "delay" else ">"
            if not (0.0 <= value < math.inf) or (name != "delay" and value == 0.0):
                flag = name.replace("_", "-")
                raise ConfigError(f"--{flag} must be finite and {bound} 0 s, got {value}")
        if self.frames not in FRAME_POLICIES:
            raise ConfigError(f"frames must be one of {', '.join(FRAME_POLICIES)}")

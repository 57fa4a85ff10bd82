"""A run as a Rerun recording (``OUT/run.rrd``): frames, path, states and terrain on one timeline.

Everything is logged on the timeline ``t`` (the log's time, s) so that the
Rerun viewer scrubs through the run:

- ``camera/image``: each classified frame, its file's bytes (JPEG/PNG);
- ``camera/roi``: the region of interest box, labelled with the frame's
  label and vote share; ``camera/footprint``: the footprint polygon in the
  image; ``camera/tiles``: the tiles that voted, coloured by their vote;
- ``world/path``: the estimated path coloured by the confirmed terrain
  (static, z = 0); ``world/measured``: the measured positions (static);
  ``world/robot``: the robot's pose at each row (a transform), drawn as an
  arrow along its heading;
- ``states/<name>/estimate``: every state column at each row, and
  ``states/<name>/lower``, ``upper``: its ±2σ band;
- ``terrain``: the starting terrain and each confirmed change (reset,
  restored, prior).

The world is x forward, y left, z up (``RIGHT_HAND_Z_UP``). Rows go in as
columns (:meth:`rerun.RecordingStream.send_columns`): 10⁵ rows take well
under a second. This module imports ``rerun`` (the ``[viz]`` extra): import
it only when a recording is asked for.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from terrain_odom.estimation.odometry import OdometryResult
from terrain_odom.records import WheelLog
from terrain_odom.reporting.figure import colour_of, terrain_colours

__all__ = ["APPLICATION_ID", "TIMELINE", "RecordedFrame", "record_run", "frame_media_type"]

APPLICATION_ID = "terrain-odom"
"""The Rerun application id of every recording."""

TIMELINE = "t"
"""The one timeline: the log's time, s."""

_MEDIA_TYPES = {".jpg": "image/jpeg", ".jpeg": "image/jpeg", ".png": "image/png"}
_BAND = ("lower", "estimate", "upper")


@dataclass(frozen=True)
class RecordedFrame:
    """One camera frame of the recording.

    Attributes
    ----------
    t : float
        Frame time, s.
    data : bytes
        The encoded image (JPEG or PNG).
    media_type : str
        ``"image/jpeg"`` or ``"image/png"``.
    label : str
        The frame's label (``""``: not classified).
    confidence : float
        Its vote share, 0-1.
    box : tuple of 4 int, optional
        Region of interest ``(x0, y0, x1, y1)``, px.
    polygon : ndarray, shape (M, 2), optional
        The footprint in the image, px.
    tiles : ndarray of int, shape (n, 4), optional
        Boxes of the tiles that voted ``(x0, y0, x1, y1)``, px.
    votes : sequence of str
        Each tile's label.
    """

    t: float
    data: bytes
    media_type: str
    label: str
    confidence: float
    box: tuple[int, int, int, int] | None = None
    polygon: np.ndarray | None = None
    tiles: np.ndarray | None = None
    votes: Sequence[str] = ()


def frame_media_type(suffix: str) -> str | None:
    """Return the media type of a frame file that Rerun decodes as it is, else None.

    Examples
    --------
    >>> frame_media_type(".JPG"), frame_media_type(".tif")
    ('image/jpeg', None)
    """
    return _MEDIA_TYPES.get(suffix.lower())


def _rgb(colour: str) -> tuple[int, int, int]:
    """``"#1b9e77"`` to ``(27, 158, 119)``."""
    value = int(colour.lstrip("#"), 16)
    return (value >> 16) & 255, (value >> 8) & 255, value & 255


def _blueprint(names: Sequence[str], camera: bool) -> rrb.Blueprint:
    """Camera and world side by side, the states below, the terrain log beside them."""
    top: list[rrb.View] = [rrb.Spatial2DView(origin="camera", name="camera")] if camera else []
    top.append(rrb.Spatial3DView(origin="world", name="world (x forward, y left, z up)"))
    plots = [rrb.TimeSeriesView(origin=f"states/{name}", name=name) for name in names]
    bottom = rrb.Horizontal(rrb.Grid(*plots), rrb.TextLogView(origin="terrain", name="terrain"))
    return rrb.Blueprint(rrb.Vertical(rrb.Horizontal(*top), bottom), collapse_panels=True)


def _log_world(stream: rr.RecordingStream, log: WheelLog, result: OdometryResult,
               colours: dict[str, str], arrow: float) -> None:  # fmt: skip
    """Log the path (per terrain run), the measured positions and the moving robot."""
    stream.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    xy = result.states[:, :2]
    labels = np.asarray(result.terrain).astype(str)
    starts = np.concatenate(([0], np.flatnonzero(labels[1:] != labels[:-1]) + 1, [len(labels)]))
    strips = [xy[a : min(b + 1, len(xy))] for a, b in zip(starts[:-1], starts[1:], strict=True)]
    stream.log(
        "world/path",
        rr.LineStrips3D(
            [np.column_stack((s, np.zeros(len(s)))) for s in strips],
            colors=[_rgb(colour_of(colours, labels[a])) for a in starts[:-1]],
            labels=[labels[a] or "no terrain" for a in starts[:-1]],
        ),
        static=True,
    )
    measured = log.pose[log.has_position, :2]
    stream.log(
        "world/measured",
        rr.Points3D(np.column_stack((measured, np.zeros(len(measured)))), colors=(60, 60, 60)),
        static=True,
    )
    stream.log("world/robot", rr.Arrows3D(vectors=[(arrow, 0.0, 0.0)]), static=True)
    yaw = result.states[:, 2]
    zeros = np.zeros(len(yaw))
    stream.send_columns(
        "world/robot",
        indexes=[rr.TimeColumn(TIMELINE, duration=log.t)],
        columns=rr.Transform3D.columns(
            translation=np.column_stack((xy, zeros)),
            quaternion=np.column_stack((zeros, zeros, np.sin(yaw / 2), np.cos(yaw / 2))),
        ),
    )


def _log_states(stream: rr.RecordingStream, t: np.ndarray, result: OdometryResult) -> None:
    """Log each state column with its ±2σ band, one column per series."""
    time = [rr.TimeColumn(TIMELINE, duration=t)]
    for i, name in enumerate(result.names):
        value, sigma = result.states[:, i], result.stds[:, i]
        for part, series in zip(_BAND, (value - 2 * sigma, value, value + 2 * sigma), strict=True):
            entity = f"states/{name}/{part}"
            style = rr.SeriesLines(
                names=name if part == "estimate" else f"{name} {part[:2]}. 2σ",
                widths=2.0 if part == "estimate" else 0.5,
            )
            stream.log(entity, style, static=True)
            stream.send_columns(entity, indexes=time, columns=rr.Scalars.columns(scalars=series))


def _log_terrain(stream: rr.RecordingStream, t: np.ndarray, result: OdometryResult) -> None:
    """Log the starting terrain and each confirmed change as text lines."""
    first = str(result.terrain[0]) if len(result.terrain) else ""
    if first:
        stream.set_time(TIMELINE, duration=float(t[0]))
        stream.log("terrain", rr.TextLog(f"start on {first}"))
    for change in result.changes:
        how = [
            what
            for what, done in (
                ("covariance reset", change.reset),
                ("remembered ICRs restored", change.restored),
                ("offline prior taken", change.prior),
            )
            if done
        ]
        seen = "" if change.t_confirmed is None else f" (confirmed at {change.t_confirmed:.2f} s)"
        text = f"{change.previous or 'start'} -> {change.label}{seen}: {', '.join(how) or 'noted'}"
        stream.set_time(TIMELINE, duration=change.t)
        stream.log("terrain", rr.TextLog(text))


def _log_frame(stream: rr.RecordingStream, frame: RecordedFrame, colours: dict[str, str]) -> None:
    """Log one frame: its image, region of interest, footprint and tile votes (or clear them)."""
    stream.set_time(TIMELINE, duration=frame.t)
    stream.log("camera/image", rr.EncodedImage(contents=frame.data, media_type=frame.media_type))
    if frame.box is None:
        for entity in ("camera/roi", "camera/footprint", "camera/tiles"):
            stream.log(entity, rr.Clear(recursive=False))
        return
    text = f"{frame.label} {frame.confidence:.0%}" if frame.label else "not classified"
    stream.log(
        "camera/roi",
        rr.Boxes2D(array=frame.box, array_format=rr.Box2DFormat.XYXY, labels=text,
                   colors=(255, 255, 255)),
    )  # fmt: skip
    if frame.polygon is None:
        stream.log("camera/footprint", rr.Clear(recursive=False))
    else:
        closed = np.vstack((frame.polygon, frame.polygon[:1]))
        stream.log("camera/footprint", rr.LineStrips2D([closed], colors=(255, 220, 0)))
    if frame.tiles is None or not len(frame.tiles):
        stream.log("camera/tiles", rr.Clear(recursive=False))
    else:
        stream.log(
            "camera/tiles",
            rr.Boxes2D(array=frame.tiles, array_format=rr.Box2DFormat.XYXY,
                       colors=[_rgb(colour_of(colours, v)) for v in frame.votes]),
        )  # fmt: skip


def record_run(
    handle: BinaryIO,
    log: WheelLog,
    result: OdometryResult,
    frames: Iterable[RecordedFrame] = (),
    *,
    labels: Iterable[str] = (),
    arrow: float = 1.0,
) -> int:
    """Write a run as a Rerun recording (``.rrd`` bytes) into ``handle``; return the frames logged.

    Parameters
    ----------
    handle : binary file
        Where the encoded recording goes, written at the end (the stream
        holds it in memory until then: about the frame files' size).
    log : WheelLog
        The run's (calibrated) log: its times and measured positions.
    result : OdometryResult
        The run's states, standard deviations, confirmed terrain and changes.
    frames : iterable of RecordedFrame
        The camera frames, in time order (consumed one by one).
    labels : iterable of str
        Terrain classes to colour besides those of the run (e.g. the classifier's).
    arrow : float
        Length of the arrow drawn along the robot's heading, m.
    """
    stream = rr.RecordingStream(APPLICATION_ID)
    stream.set_log_time_enabled(False)  # one timeline: t, not the wall clock
    stream.set_log_tick_enabled(False)
    sink = rr.binary_stream(recording=stream)
    camera = iter(frames)
    first = next(camera, None)
    stream.send_blueprint(_blueprint(result.names, camera=first is not None))
    colours = terrain_colours([*result.terrain, *labels])
    _log_world(stream, log, result, colours, arrow)
    _log_states(stream, log.t, result)
    _log_terrain(stream, log.t, result)
    logged = 0
    for frame in itertools.chain(() if first is None else (first,), camera):
        _log_frame(stream, frame, colours)
        logged += 1
    stream.disconnect()  # ends the stream: its footer (manifest) is encoded
    handle.write(sink.read(flush=True) or b"")  # read once: partial reads make two manifests
    return logged

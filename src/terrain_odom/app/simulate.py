"""Write a simulated run to a folder.

Layout of ``OUT``:

- ``log.csv``: wheel log (``t,v_l,v_r,x,y,yaw,terrain``): measured track
  speeds (m/s), GPS-like poses (empty cells on rows without one), true
  terrain under the robot.
- ``groundtruth.csv``: ``t,x,y,yaw,y_l,y_r,x_icr,terrain,alpha,v_l,v_r``, one
  row per wheel sample: true pose at ``t``, true parameters and noise-free
  track speeds held from ``t`` to the next row.
- ``frames/NNNNNN.png`` (or ``.jpg``, JPEG quality 90, with ``frame_format="jpg"``)
  and ``frames.csv`` (``t,file``, file relative to ``OUT``).
- ``patches/<terrain>/NNNN.png``: labelled training patches (the labelled-image
  layout of ``terrain-odom train``), from ground the run does not drive over;
  ``patches.csv`` (``file,terrain,x,y,yaw,u0,v0``): the robot pose each was
  rendered from and the crop's top-left pixel.
- ``config.yaml``: the ``robot`` and ``camera`` configuration sections the run
  was simulated with (``terrain-odom run --config OUT/config.yaml``), and
  ``pose_sensor`` when the scenario mounts the GPS antenna or the IMU off
  the robot's reference (its ``antenna``, ``heading_offset``).
- ``map.png`` (``map.jpg`` with ``frame_format="jpg"``): the ground map,
  downscaled to at most 2000 px, with the true path in red.
- ``plots/map.png``: the map with metre axes, the true path coloured by terrain,
  start and end marked.
- ``simulation.json``: scenario, seed, terrain table, camera, robot, counts.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from terrain_odom.app.plots import write_figures
from terrain_odom.io import TrajectoryWriter
from terrain_odom.io.folder import replacing
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import report_header, write_json
from terrain_odom.reporting.map import map_figure
from terrain_odom.sim.scenarios import Scenario
from terrain_odom.sim.simulation import Simulation, iter_frames, sample_patches

__all__ = ["FRAME_FORMATS", "SimOutput", "write_simulation"]

FRAME_FORMATS = ("png", "jpg")
MAP_PLOT = "plots/map.png"
"""The map figure, in the output folder."""
JPEG_QUALITY = 90

LOG_COLUMNS = ("t", "v_l", "v_r", "x", "y", "yaw", "terrain")
TRUTH_COLUMNS = ("t", "x", "y", "yaw", "y_l", "y_r", "x_icr", "terrain", "alpha", "v_l", "v_r")


@dataclass(frozen=True)
class SimOutput:
    """What :func:`write_simulation` wrote (paths and counts).

    Attributes
    ----------
    simulation : Simulation
        The run written.
    out_dir : Path
        The output folder.
    log_csv, groundtruth_csv, metadata_json : Path
    frames_csv : Path or None
        None when no frames were rendered.
    patches_dir : Path or None
        None when no patches were rendered.
    map_preview : Path
        ``map.png`` or ``map.jpg``.
    map_preview_resolution : float
        Ground size of a preview pixel, m.
    rows, pose_rows, frames : int
        Wheel-log rows, rows with a pose measurement, camera frames.
    patches : dict of str to int
        Training patches per terrain.
    config_yaml : Path or None
        ``config.yaml``, the robot and camera of the run.
    map_plot : Path or None
        ``plots/map.png``: the map with metre axes and the path by terrain.
    """

    simulation: Simulation = field(repr=False, compare=False)
    out_dir: Path
    log_csv: Path
    groundtruth_csv: Path
    frames_csv: Path | None
    patches_dir: Path | None
    metadata_json: Path
    map_preview: Path
    map_preview_resolution: float
    rows: int
    pose_rows: int
    frames: int
    patches: dict[str, int] = field(default_factory=dict)
    config_yaml: Path | None = None
    map_plot: Path | None = None

    def to_dict(self) -> dict[str, Any]:
        """Return the content of ``simulation.json``."""
        sim = self.simulation
        sc = sim.scenario
        return {
            **report_header("simulate"),
            "scenario": sc.name,
            "description": sc.description,
            "seed": sim.seed,
            "duration_s": sc.duration,
            "rates_hz": {"wheel": sc.wheel_rate, "pose": sc.pose_rate, "frame": sc.frame_rate},
            "noise": {
                "encoder_m_s": sc.sigma_encoder,
                "pose_xy_m": sc.sigma_xy,
                "pose_yaw_rad": sc.sigma_yaw,
                "pixel": sc.lighting.noise,
            },
            "terrains": {k: dataclasses.asdict(v) for k, v in sc.table.items()},
            "map": {
                "extent_m": list(sim.ground.extent),
                "resolution_m": sim.ground.resolution,
                "textures": "skimage.data photos (grass, gravel, brick), mirror-tiled and tinted",
                "preview": {
                    "file": self.map_preview.name,
                    "resolution_m": self.map_preview_resolution,
                },
                "plot": None if self.map_plot is None else MAP_PLOT,
            },
            "camera": dataclasses.asdict(sc.camera),
            "robot": dataclasses.asdict(sc.robot),
            "pose_sensor": _pose_sensor(sc),
            "counts": {
                "rows": self.rows,
                "pose_rows": self.pose_rows,
                "frames": self.frames,
                "patches": self.patches,
            },
        }


def _write_log(sim: Simulation, path: Path) -> None:
    m, pose = sim.motion, sim.measured_pose
    with TrajectoryWriter(path, LOG_COLUMNS) as writer:
        for k in range(m.t.size):
            writer.write(
                {
                    "t": round(float(m.t[k]), 6),
                    "v_l": float(sim.v_l[k]),
                    "v_r": float(sim.v_r[k]),
                    "x": float(pose[k, 0]),
                    "y": float(pose[k, 1]),
                    "yaw": float(pose[k, 2]),
                    "terrain": str(m.terrain[k]),
                }
            )


def _write_truth(sim: Simulation, path: Path) -> None:
    m = sim.motion
    with TrajectoryWriter(path, TRUTH_COLUMNS) as writer:
        for k in range(m.t.size):
            y_l, y_r, x_icr, alpha = (float(a) for a in m.params[k])
            writer.write(
                {
                    "t": round(float(m.t[k]), 6),
                    "x": float(m.pose[k, 0]),
                    "y": float(m.pose[k, 1]),
                    "yaw": float(m.pose[k, 2]),
                    "y_l": y_l,
                    "y_r": y_r,
                    "x_icr": x_icr,
                    "terrain": str(m.terrain[k]),
                    "alpha": alpha,
                    "v_l": float(m.v_l[k]),
                    "v_r": float(m.v_r[k]),
                }
            )


def _write_image(path: Path, rgb: np.ndarray) -> None:
    """Write an RGB image; the format follows the suffix (JPEG at quality 90)."""
    params = [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY] if path.suffix == ".jpg" else []
    if not cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), params):
        raise OSError(f"cannot write {path}")


def _write_frames(sim: Simulation, out_dir: Path, frame_format: str = "png") -> int:
    (out_dir / "frames").mkdir(exist_ok=True)
    count = 0
    with TrajectoryWriter(out_dir / "frames.csv", ("t", "file")) as writer:
        for count, (t, frame) in enumerate(iter_frames(sim), start=1):
            name = f"frames/{count - 1:06d}.{frame_format}"
            _write_image(out_dir / name, frame)
            writer.write({"t": round(t, 6), "file": name})
    return count


def _write_patches(sim: Simulation, out_dir: Path) -> dict[str, int]:
    counts = dict.fromkeys(sim.ground.terrains, 0)
    columns = ("file", "terrain", "x", "y", "yaw", "u0", "v0")
    with TrajectoryWriter(out_dir / "patches.csv", columns) as writer:
        for patch in sample_patches(sim):
            folder = out_dir / "patches" / patch.terrain
            folder.mkdir(parents=True, exist_ok=True)
            name = f"patches/{patch.terrain}/{counts[patch.terrain]:04d}.png"
            _write_image(out_dir / name, patch.image)
            counts[patch.terrain] += 1
            x, y, yaw = (float(a) for a in patch.pose)
            u0, v0 = patch.corner
            writer.write(
                {
                    "file": name,
                    "terrain": patch.terrain,
                    "x": x,
                    "y": y,
                    "yaw": yaw,
                    "u0": u0,
                    "v0": v0,
                }
            )
    return counts


SIM_ICR_SIGMA_Q = {"y_l": 0.005, "y_r": 0.005, "x_icr": 0.005, "alpha": 0.001}
"""ICR random walk written with a simulated run (m/sqrt(s); alpha 1/sqrt(s)).

Simulated terrains have constant ICRs, so the filter needs little random
walk: terrain changes are followed by the covariance resets. The defaults
(0.02) would let the estimate wander by about 0.1 m over 20 s.
"""


def _pose_sensor(scenario: Scenario) -> dict[str, float]:
    """Return the ``pose_sensor`` section of a scenario's mounting (antenna, heading offset)."""
    mounting = scenario.mounting
    return {
        "antenna_x": mounting.antenna_x,
        "antenna_y": mounting.antenna_y,
        "heading_offset": mounting.heading_offset,
    }


def _write_config(sim: Simulation, path: Path) -> None:
    sections: dict[str, Any] = {
        "robot": {  # a value left null (robot.length) is the default: left out
            k: v for k, v in dataclasses.asdict(sim.scenario.robot).items() if v is not None
        },
        "camera": dataclasses.asdict(sim.scenario.camera),
        "ekf": {"sigma_q": SIM_ICR_SIGMA_Q},
    }
    header = (
        f"# robot, camera and ICR random walk of the simulated run "
        f"({sim.scenario.name}, seed {sim.seed})\n"
    )
    sensor = _pose_sensor(sim.scenario)
    if any(sensor.values()):
        sections["pose_sensor"] = sensor
        header += "# pose_sensor: the simulated mounting; without it the log checks stop a run\n"
    path.write_text(header + yaml.safe_dump(sections, sort_keys=False), encoding="utf-8")


def _downscaled(image: np.ndarray, max_side: int) -> tuple[np.ndarray, float]:
    """Return ``image`` shrunk to at most ``max_side`` px a side, and the scale applied."""
    scale = min(1.0, max_side / max(image.shape[:2]))
    size = (round(image.shape[1] * scale), round(image.shape[0] * scale))
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA), scale


def _write_map_plot(sim: Simulation, path: Path) -> Path:
    """Write the map with metre axes and the true path by terrain (a figure); return its path."""
    image, _ = _downscaled(sim.ground.image, 1200)
    motion = sim.motion
    draw = functools.partial(
        map_figure, image, sim.ground.extent, motion.pose[:, :2], motion.terrain
    )
    return write_figures(path.parent, {path.name: draw})[0]


def _write_map_preview(sim: Simulation, path: Path, max_side: int = 2000) -> float:
    """Write the downscaled map with the true path; return its resolution, m/px."""
    ground = sim.ground
    preview, scale = _downscaled(ground.image, max_side)
    uv = (ground.world_to_pixel(sim.motion.pose[:, :2]) + 0.5) * scale - 0.5
    pts = np.rint(uv * 16).astype(np.int32)
    cv2.polylines(preview, [pts], False, (255, 0, 0), 2, lineType=cv2.LINE_AA, shift=4)
    _write_image(path, preview)
    return ground.resolution / scale


def write_simulation(
    sim: Simulation,
    out_dir: str | Path,
    *,
    frames: bool = True,
    patches: bool = True,
    frame_format: str = "png",
    inputs: Iterable[str | Path | None] = (),
) -> SimOutput:
    """Write a simulated run to ``out_dir`` (created if needed; its own previous files replaced).

    Parameters
    ----------
    sim : Simulation
    out_dir : str or Path
        Output folder.
    frames, patches : bool
        Render the camera frames / the training patches.
    frame_format : {"png", "jpg"}
        Image format of the frames and the map preview: lossless PNG
        (default) or JPEG at quality 90 (about 6x smaller; training patches
        stay PNG).
    inputs : iterable of str or Path, optional
        Files the simulation was made from (e.g. its configuration), which
        the output must not overwrite.

    Returns
    -------
    SimOutput

    Raises
    ------
    InputFileError
        A file to write is one of ``inputs``.
    """
    if frame_format not in FRAME_FORMATS:
        raise ValueError(f"frame_format must be one of {FRAME_FORMATS}, got {frame_format!r}")
    out_dir = Path(out_dir)
    files = ("log.csv", "groundtruth.csv", "frames.csv", "config.yaml", "simulation.json")
    check_outputs(inputs, [out_dir / name for name in (*files, f"map.{frame_format}", MAP_PLOT)])
    names = [*files, f"map.{frame_format}", MAP_PLOT, "frames/", "patches/"]
    with replacing(out_dir, "simulate", names):  # its previous files replaced, never another's
        _write_log(sim, out_dir / "log.csv")
        _write_truth(sim, out_dir / "groundtruth.csv")
        frame_count = _write_frames(sim, out_dir, frame_format) if frames else 0
        patch_counts = _write_patches(sim, out_dir) if patches else {}
        _write_config(sim, out_dir / "config.yaml")
        preview = out_dir / f"map.{frame_format}"
        preview_resolution = _write_map_preview(sim, preview)
        output = SimOutput(
            simulation=sim,
            out_dir=out_dir,
            log_csv=out_dir / "log.csv",
            groundtruth_csv=out_dir / "groundtruth.csv",
            frames_csv=out_dir / "frames.csv" if frames else None,
            patches_dir=out_dir / "patches" if patches else None,
            metadata_json=out_dir / "simulation.json",
            map_preview=preview,
            map_preview_resolution=preview_resolution,
            rows=int(sim.motion.t.size),
            pose_rows=int(np.isfinite(sim.measured_pose[:, 0]).sum()),
            frames=frame_count,
            patches=patch_counts,
            config_yaml=out_dir / "config.yaml",
            map_plot=_write_map_plot(sim, out_dir / MAP_PLOT),
        )
        write_json(output.metadata_json, output.to_dict())
    return output

"""Tests of :mod:`terrain_odom.io.trajectory`: CSV trajectories and TUM files."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import terrain_odom
from terrain_odom.errors import InputFileError
from terrain_odom.io import TrajectoryWriter, read_trajectory_csv, write_tum
from terrain_odom.io.trajectory import trajectory_columns

TRICKY_FLOATS = [0.1, 1.0 / 3.0, -2.5e-300, 1.7e9 + 0.123456789, 5e-324, 1e308, -0.0, float("inf")]


# --- TrajectoryWriter / read_trajectory_csv -------------------------------------


def test_round_trip_is_exact_for_floats_ints_nan_and_strings(tmp_path: Path) -> None:
    """Writer and reader round-trip floats bit-exactly, ints, NaN and CSV-quoted text."""
    path = tmp_path / "trajectory.csv"
    labels = ["grass", "asphalt, wet", 'say "hi"', " padded "]
    with TrajectoryWriter(path, ["t", "x", "segment", "terrain"]) as writer:
        for k, value in enumerate(TRICKY_FLOATS):
            writer.write(
                {
                    "t": value,
                    "x": np.float64(np.nan) if k % 3 == 0 else np.float32(k / 3),
                    "segment": np.int64(k // 4),
                    "terrain": labels[k % len(labels)],
                }
            )

    back = read_trajectory_csv(path)

    assert list(back) == ["t", "x", "segment", "terrain"]
    np.testing.assert_array_equal(back["t"], TRICKY_FLOATS)
    assert np.signbit(back["t"][6])  # -0.0 keeps its sign
    expected_x = [np.nan if k % 3 == 0 else float(np.float32(k / 3)) for k in range(8)]
    np.testing.assert_array_equal(back["x"], expected_x)
    np.testing.assert_array_equal(back["segment"], [0, 0, 0, 0, 1, 1, 1, 1])
    assert back["terrain"].tolist() == [label.strip() for label in labels * 2]


def test_nan_is_written_as_an_empty_cell(tmp_path: Path) -> None:
    """NaN is written as an empty cell."""
    path = tmp_path / "trajectory.csv"
    with TrajectoryWriter(path, ["t", "yaw"]) as writer:
        writer.write({"t": 1.5, "yaw": float("nan")})

    assert path.read_text() == "t,yaw\n1.5,\n"


def test_writer_without_rows_reads_back_as_empty_columns(tmp_path: Path) -> None:
    """A file with only the header reads back as empty float columns."""
    path = tmp_path / "trajectory.csv"
    TrajectoryWriter(path, ["t", "x"]).close()

    back = read_trajectory_csv(path)

    assert list(back) == ["t", "x"]
    assert all(column.shape == (0,) and column.dtype == np.float64 for column in back.values())


def test_columns_are_typed_by_content(tmp_path: Path) -> None:
    """Numeric columns become float (NaN if empty), others stripped str."""
    path = tmp_path / "trajectory.csv"
    path.write_text("t,empty,label,mixed\n0,,grass,1\n1,,grass,\n2,, gravel ,n/a\n")

    back = read_trajectory_csv(path)

    assert back["t"].dtype == np.float64 and back["empty"].dtype == np.float64
    assert np.isnan(back["empty"]).all()
    assert back["label"].tolist() == ["grass", "grass", "gravel"]
    assert back["mixed"].tolist() == ["1", "", "n/a"]


def test_rows_are_on_disk_after_flush_rows_without_closing(tmp_path: Path) -> None:
    """Rows reach the file once ``flush_rows`` are pending, before closing."""
    path = tmp_path / "trajectory.csv"
    writer = TrajectoryWriter(path, ["t"], flush_rows=2, flush_seconds=1e9)
    try:
        writer.write({"t": 0.0})
        assert path.read_text() == "t\n"
        writer.write({"t": 1.0})
        assert path.read_text() == "t\n0.0\n1.0\n"
    finally:
        writer.close()


def test_rows_are_on_disk_after_flush_seconds_without_closing(tmp_path: Path) -> None:
    """Rows reach the file at the first write after ``flush_seconds``."""
    path = tmp_path / "trajectory.csv"
    with TrajectoryWriter(path, ["t"], flush_rows=10**6, flush_seconds=0.05) as writer:
        writer.write({"t": 0.0})
        time.sleep(0.1)
        writer.write({"t": 1.0})
        assert read_trajectory_csv(path)["t"].tolist() == [0.0, 1.0]


def test_killed_writer_leaves_the_flushed_rows_readable(tmp_path: Path) -> None:
    """A process killed with SIGKILL leaves its flushed rows readable."""
    path = tmp_path / "trajectory.csv"
    script = textwrap.dedent(
        f"""
        import os, signal
        from terrain_odom.io import TrajectoryWriter

        writer = TrajectoryWriter({str(path)!r}, ["t", "x"], flush_rows=5, flush_seconds=1e9)
        for k in range(7):  # rows 0-4 are flushed, rows 5-6 still buffered when killed
            writer.write({{"t": k * 0.1, "x": float(k)}})
        os.kill(os.getpid(), signal.SIGKILL)
        """
    )
    source_dir = Path(terrain_odom.__file__).resolve().parents[1]
    environment = {**os.environ, "PYTHONPATH": str(source_dir)}
    result = subprocess.run([sys.executable, "-c", script], env=environment, timeout=60)
    assert result.returncode == -9

    back = read_trajectory_csv(path)

    np.testing.assert_array_equal(back["t"], [0.0, 0.1, 0.2, 0.30000000000000004, 0.4])
    np.testing.assert_array_equal(back["x"], [0.0, 1.0, 2.0, 3.0, 4.0])


def test_writer_closes_on_exception_and_keeps_rows(tmp_path: Path) -> None:
    """Leaving the with block by an exception closes the file with its rows."""
    path = tmp_path / "trajectory.csv"
    with pytest.raises(RuntimeError), TrajectoryWriter(path, ["t"], flush_rows=100) as writer:
        writer.write({"t": 2.0})
        raise RuntimeError("estimator failed")

    assert writer.closed
    assert read_trajectory_csv(path)["t"].tolist() == [2.0]


@pytest.mark.parametrize(
    ("row", "match"),
    [
        ({"t": 1.0}, r"missing \['x'\], extra \[\]"),
        ({"t": 1.0, "x": 2.0, "z": 3.0}, r"extra \['z'\]"),
    ],
)
def test_write_rejects_rows_not_matching_the_columns(tmp_path: Path, row: dict, match: str) -> None:
    """A row must have exactly the writer's columns."""
    with TrajectoryWriter(tmp_path / "trajectory.csv", ["t", "x"]) as writer:
        with pytest.raises(ValueError, match=match):
            writer.write(row)


@pytest.mark.parametrize("value", [None, True, [1.0], 1 + 2j])
def test_write_rejects_values_that_are_not_str_or_real(tmp_path: Path, value: object) -> None:
    """Only str and real numbers can be written."""
    with TrajectoryWriter(tmp_path / "trajectory.csv", ["t"]) as writer:
        with pytest.raises(TypeError, match="cannot write"):
            writer.write({"t": value})  # type: ignore[dict-item]


def test_write_after_close_fails(tmp_path: Path) -> None:
    """Closing twice is harmless; writing after closing fails."""
    writer = TrajectoryWriter(tmp_path / "trajectory.csv", ["t"])
    writer.close()
    writer.close()

    with pytest.raises(ValueError, match="closed"):
        writer.write({"t": 0.0})


@pytest.mark.parametrize("columns", [[], ["t", "t"], ["t", ""], [" t"]])
def test_writer_rejects_bad_column_names(tmp_path: Path, columns: list[str]) -> None:
    """Empty, padded or repeated column names are rejected before creating the file."""
    with pytest.raises(ValueError, match="column"):
        TrajectoryWriter(tmp_path / "trajectory.csv", columns)
    assert not (tmp_path / "trajectory.csv").exists()


@pytest.mark.parametrize(("rows", "seconds"), [(0, 1.0), (10, 0.0), (10, float("nan"))])
def test_writer_rejects_bad_flush_settings(tmp_path: Path, rows: int, seconds: float) -> None:
    """Flush settings must be positive."""
    with pytest.raises(ValueError, match="flush"):
        TrajectoryWriter(tmp_path / "trajectory.csv", ["t"], flush_rows=rows, flush_seconds=seconds)


def test_read_missing_trajectory(tmp_path: Path) -> None:
    """A missing trajectory file is named in the message."""
    path = tmp_path / "missing.csv"

    with pytest.raises(InputFileError, match=f"^{path}: file does not exist$"):
        read_trajectory_csv(path)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", ": file is empty"),
        ("t,x\n0,1\n1\n", ", line 3, column 'x': row has 1 cells but the header has 2"),
        ("t,x,t\n0,1,2\n", ", line 1, column 't': column appears more than once in the header"),
        ("t,,x\n0,1,2\n", ", line 1: column 2 of the header has no name"),
    ],
)
def test_read_malformed_trajectory(tmp_path: Path, text: str, message: str) -> None:
    """Empty files, ragged rows and bad headers give one-line messages."""
    path = tmp_path / "trajectory.csv"
    path.write_text(text)

    with pytest.raises(InputFileError) as info:
        read_trajectory_csv(path)

    assert str(info.value).startswith(f"{path}{message}")


# --- write_tum ------------------------------------------------------------------


def planar_trajectory(n: int = 50) -> tuple[np.ndarray, ...]:
    """Return times, s, positions, m, and yaw, rad, of a drive turning through every heading."""
    t = 1.7e9 + np.arange(n) * 0.1 + 1e-4
    yaw = np.linspace(-np.pi + 1e-3, np.pi, n)
    return t, np.cumsum(np.cos(yaw)), np.cumsum(np.sin(yaw)), yaw


def test_write_tum_reads_back_with_evo(tmp_path: Path) -> None:
    """The evo package reads the TUM file back with the same times, positions and yaw."""
    file_interface = pytest.importorskip("evo.tools.file_interface")
    t, x, y, yaw = planar_trajectory()
    path = tmp_path / "trajectory.tum"

    write_tum(path, t, x, y, yaw)
    trajectory = file_interface.read_tum_trajectory_file(str(path))

    np.testing.assert_array_equal(trajectory.timestamps, t)
    np.testing.assert_array_equal(trajectory.positions_xyz, np.column_stack([x, y, 0 * x]))
    quaternion = trajectory.orientations_quat_wxyz
    np.testing.assert_allclose(np.linalg.norm(quaternion, axis=1), 1.0, atol=1e-15)
    np.testing.assert_array_equal(quaternion[:, 1:3], 0.0)
    yaw_back = 2.0 * np.arctan2(quaternion[:, 3], quaternion[:, 0])
    np.testing.assert_allclose(np.angle(np.exp(1j * (yaw_back - yaw))), 0.0, atol=1e-12)


def test_write_tum_lines_round_trip_exactly(tmp_path: Path) -> None:
    """TUM values round-trip exactly; the quaternion is a rotation about z."""
    t, x, y, yaw = planar_trajectory()
    path = tmp_path / "trajectory.tum"

    write_tum(path, t, x, y, yaw)
    data = np.loadtxt(path, comments="#")

    assert data.shape == (t.size, 8)
    np.testing.assert_array_equal(data[:, :4], np.column_stack([t, x, y, 0 * t]))
    np.testing.assert_array_equal(data[:, 6:], np.column_stack([np.sin(yaw / 2), np.cos(yaw / 2)]))


def test_write_tum_replaces_atomically_and_leaves_no_temporary(tmp_path: Path) -> None:
    """An existing file is replaced and no temporary file is left behind."""
    path = tmp_path / "trajectory.tum"
    path.write_text("old content\n")

    write_tum(path, *planar_trajectory(3))

    assert [p.name for p in tmp_path.iterdir()] == ["trajectory.tum"]
    assert len(path.read_text().splitlines()) == 4


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda a: a[:-1], "shape"),
        (lambda a: a.reshape(-1, 1), "1-D"),
        (lambda a: np.where(np.arange(a.size) == 2, np.nan, a), r"\[2\] is nan"),
    ],
)
def test_write_tum_rejects_bad_arrays_and_keeps_the_old_file(
    tmp_path: Path, change: object, match: str
) -> None:
    """Bad arrays raise ValueError and leave the existing file untouched."""
    path = tmp_path / "trajectory.tum"
    path.write_text("old content\n")
    t, x, y, yaw = planar_trajectory(5)

    with pytest.raises(ValueError, match=match):
        write_tum(path, t, x, change(y), yaw)  # type: ignore[operator]

    assert path.read_text() == "old content\n"
    assert [p.name for p in tmp_path.iterdir()] == ["trajectory.tum"]


def test_trajectory_columns() -> None:
    assert trajectory_columns(("x", "y", "yaw", "y_l", "y_r", "x_icr", "alpha")) == [
        "t",
        "x",
        "y",
        "yaw",
        "y_l",
        "y_r",
        "x_icr",
        "terrain",
        "alpha",
        "std_x",
        "std_y",
        "std_yaw",
        "std_y_l",
        "std_y_r",
        "std_x_icr",
        "std_alpha",
    ]

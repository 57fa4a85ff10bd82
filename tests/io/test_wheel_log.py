"""Tests of :func:`terrain_odom.io.read_wheel_log` and :func:`~terrain_odom.io.wheel_log.write_wheel_log`."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.errors import InputFileError
from terrain_odom.io import read_wheel_log
from terrain_odom.io.wheel_log import write_wheel_log
from terrain_odom.records import WheelLog


@pytest.fixture
def in_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Run the test inside ``tmp_path`` so that messages name the file ``log.csv``."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def read_text(text: str, **kwargs: float) -> WheelLog:
    """Write ``text`` to ``log.csv`` in the current directory and read it."""
    Path("log.csv").write_text(text, encoding="utf-8")
    return read_wheel_log("log.csv", **kwargs)


def error_of(text: str, **kwargs: float) -> str:
    """Return the message of the InputFileError raised when reading ``text`` as ``log.csv``."""
    with pytest.raises(InputFileError) as info:
        read_text(text, **kwargs)
    message = str(info.value)
    assert "\n" not in message
    return message


# --- valid logs --------------------------------------------------------------


def test_surface_speed_log_gives_float_arrays_and_defaults() -> None:
    """A minimal log gives float64 arrays, NaN pose, no terrain and segment 0."""
    log = read_wheel_log(io.StringIO("t,v_l,v_r\n0.0,1.0,1.5\n0.01,-0.5,2\n"))

    np.testing.assert_array_equal(log.t, [0.0, 0.01])
    np.testing.assert_array_equal(log.v_l, [1.0, -0.5])
    np.testing.assert_array_equal(log.v_r, [1.5, 2.0])
    assert log.t.dtype == log.v_l.dtype == log.v_r.dtype == log.pose.dtype == np.float64
    assert log.pose.shape == (2, 3) and np.isnan(log.pose).all()
    assert log.terrain is None
    assert log.segment.dtype == np.int64 and not log.segment.any()
    assert log.source == "<stream>"


def test_angular_speeds_are_scaled_by_the_wheel_radius() -> None:
    """Angular speeds (rad/s) become surface speeds wheel_radius * omega."""
    log = read_wheel_log(io.StringIO("t,omega_l,omega_r\n0,2.0,-4.0\n"), wheel_radius=0.25)

    np.testing.assert_allclose(log.v_l, [0.5])
    np.testing.assert_allclose(log.v_r, [-1.0])


def test_surface_speeds_ignore_the_wheel_radius() -> None:
    """v_l, v_r are already surface speeds; the radius does not scale them."""
    log = read_wheel_log(io.StringIO("t,v_l,v_r\n0,2.0,-4.0\n"), wheel_radius=0.25)

    np.testing.assert_array_equal(log.v_l, [2.0])


def test_sparse_pose_is_nan_where_not_measured() -> None:
    """Empty or ``nan`` pose cells are NaN; yaw may come without x, y."""
    text = (
        "t,v_l,v_r,x,y,yaw\n0,1,1,,,\n0.1,1,1,0.5,-0.25,0.1\n0.2,1,1,,,0.2\n0.3,1,1,nan,nan,nan\n"
    )
    log = read_wheel_log(io.StringIO(text))

    np.testing.assert_array_equal(log.pose[1], [0.5, -0.25, 0.1])
    assert log.has_position.tolist() == [False, True, False, False]
    assert log.has_yaw.tolist() == [False, True, True, False]
    assert log.has_pose.tolist() == [False, True, False, False]


def test_yaw_alone_is_a_heading_only_sensor() -> None:
    """A ``yaw`` column without ``x, y`` gives NaN positions."""
    log = read_wheel_log(io.StringIO("t,v_l,v_r,yaw\n0,1,1,0.3\n0.1,1,1,\n"))

    assert np.isnan(log.pose[:, :2]).all()
    assert log.has_yaw.tolist() == [True, False]


@pytest.mark.parametrize(
    ("yaw", "wrapped"),
    [
        (np.pi, np.pi),
        (-np.pi, np.pi),
        (3.5, 3.5 - 2 * np.pi),
        (-7.0, -7.0 + 2 * np.pi),
        (0.25, 0.25),
    ],
)
def test_yaw_is_wrapped_to_minus_pi_exclusive_pi_inclusive(yaw: float, wrapped: float) -> None:
    """Yaw is wrapped to (-pi, pi] on read."""
    log = read_wheel_log(io.StringIO(f"t,v_l,v_r,x,y,yaw\n0,1,1,0,0,{yaw!r}\n"))

    assert log.pose[0, 2] == pytest.approx(wrapped, abs=1e-12)
    assert -np.pi < log.pose[0, 2] <= np.pi


def test_terrain_and_segments_with_time_restarting_in_each_segment() -> None:
    """Terrain labels and segment ids are read; time may restart in a new segment."""
    text = "t,v_l,v_r,terrain,segment\n0,1,1,grass,4\n0.1,1,1,grass,4\n0,1,1,asphalt,7\n"
    log = read_wheel_log(io.StringIO(text))

    assert log.terrain is not None
    assert log.terrain.tolist() == ["grass", "grass", "asphalt"]
    assert log.segment.tolist() == [4, 4, 7]
    assert log.segment.dtype == np.int64


def test_whitespace_is_stripped_and_unknown_columns_are_ignored() -> None:
    """Header names and cells are stripped; an unknown column is ignored."""
    text = " t , v_l ,v_r, note ,terrain\n 0.5 , 1.0 ,2.0, any text ,  gravel \n"
    log = read_wheel_log(io.StringIO(text))

    assert (log.t[0], log.v_l[0], log.v_r[0]) == (0.5, 1.0, 2.0)
    assert log.terrain is not None and log.terrain.tolist() == ["gravel"]


def test_whitespace_only_pose_cell_is_missing() -> None:
    """A pose cell of spaces only counts as empty."""
    log = read_wheel_log(io.StringIO("t,v_l,v_r,x,y,yaw\n0,1,1,  , ,  \n"))

    assert np.isnan(log.pose).all()


def test_path_crlf_and_utf8_bom(tmp_path: Path) -> None:
    """Sources as str or Path, CRLF line ends and a UTF-8 BOM are accepted."""
    path = tmp_path / "log.csv"
    path.write_bytes(b"\xef\xbb\xbft,v_l,v_r\r\n0,1,2\r\n0.1,3,4\r\n")

    for source in (path, str(path)):
        log = read_wheel_log(source)
        np.testing.assert_array_equal(log.v_r, [2.0, 4.0])
        assert log.source == str(path)


def test_open_file_handle_is_named_after_its_file(tmp_path: Path) -> None:
    """An open file handle is reported by its file name."""
    path = tmp_path / "log.csv"
    path.write_text("t,v_l,v_r\n0,1,2\n")

    with open(path, newline="") as handle:
        assert read_wheel_log(handle).source == str(path)


def test_empty_lines_are_skipped_but_counted_in_line_numbers(in_tmp: Path) -> None:
    """Empty lines are skipped yet still count for the line numbers in messages."""
    message = error_of("t,v_l,v_r\n\n0,1,1\n\n\n0.1,abc,1\n")

    assert message == "log.csv, line 6, column 'v_l': 'abc' is not a number"


def test_quoted_newline_in_an_unknown_column_keeps_line_numbers(in_tmp: Path) -> None:
    """A quoted cell spanning two lines keeps later line numbers right."""
    message = error_of('t,v_l,v_r,note\n0,1,1,"two\nlines"\n0.1,1,x,\n')

    assert message == "log.csv, line 4, column 'v_r': 'x' is not a number"


# --- errors ------------------------------------------------------------------


def test_missing_file(in_tmp: Path) -> None:
    """A missing file is named in the message."""
    with pytest.raises(InputFileError, match=r"^nope\.csv: file does not exist$"):
        read_wheel_log("nope.csv")


def test_directory_instead_of_file(in_tmp: Path) -> None:
    """A directory is reported as a file that cannot be opened."""
    with pytest.raises(InputFileError, match=r"^\.: cannot open"):
        read_wheel_log(".")


def test_empty_file(in_tmp: Path) -> None:
    """A file without any line (or only empty lines) is reported as empty."""
    assert error_of("").startswith("log.csv: file is empty")
    assert error_of("\n\n").startswith("log.csv: file is empty")


def test_header_only(in_tmp: Path) -> None:
    """A header without data rows is an error."""
    assert error_of("t,v_l,v_r\n") == "log.csv, line 1: no data rows after the header"


def test_not_utf8(in_tmp: Path) -> None:
    """Bytes that are not UTF-8 are reported, not raised as UnicodeDecodeError."""
    Path("log.csv").write_bytes(b"t,v_l,v_r\n0,1,\xff\n")

    with pytest.raises(InputFileError, match=r"^log\.csv: not a UTF-8 text file"):
        read_wheel_log("log.csv")


def test_missing_time_column(in_tmp: Path) -> None:
    """A missing ``t`` column is named with the header found."""
    message = error_of("time,v_l,v_r\n0,1,1\n")

    assert message.startswith("log.csv, line 1: missing column 't' (time, s); header is ")
    assert "'time,v_l,v_r'" in message


def test_missing_wheel_speed_columns(in_tmp: Path) -> None:
    """A log without wheel speeds names both accepted column pairs."""
    message = error_of("t,x,y,yaw\n0,1,1,0\n")

    assert message.startswith("log.csv, line 1: missing wheel-speed columns")
    assert "'v_l,v_r'" in message and "'omega_l,omega_r'" in message


@pytest.mark.parametrize(
    ("header", "missing"),
    [("t,v_l", "v_r"), ("t,v_r", "v_l"), ("t,omega_l", "omega_r"), ("t,omega_r", "omega_l")],
)
def test_half_a_wheel_speed_pair_names_the_missing_column(
    in_tmp: Path, header: str, missing: str
) -> None:
    """Half a wheel-speed pair names the missing column."""
    message = error_of(f"{header}\n0,1\n", wheel_radius=0.3)

    assert message.startswith(f"log.csv, line 1: missing column {missing!r}")


def test_both_wheel_speed_pairs_are_ambiguous(in_tmp: Path) -> None:
    """Both wheel-speed pairs at once are ambiguous."""
    message = error_of("t,v_l,v_r,omega_l,omega_r\n0,1,1,1,1\n", wheel_radius=0.3)

    assert message.startswith("log.csv, line 1: both 'v_l,v_r' and 'omega_l,omega_r'")
    assert "keep only one pair" in message


@pytest.mark.parametrize("radius", [None, 0.0, -0.3, float("nan"), float("inf")])
def test_angular_speeds_need_a_positive_wheel_radius(in_tmp: Path, radius: float | None) -> None:
    """Angular speed columns need a finite wheel_radius > 0."""
    Path("log.csv").write_text("t,omega_l,omega_r\n0,1,1\n")

    with pytest.raises(InputFileError, match=r"^log\.csv, line 1: .*wheel radius > 0 m"):
        read_wheel_log("log.csv", wheel_radius=radius)


def test_repeated_column(in_tmp: Path) -> None:
    """A column used by the reader may appear only once."""
    message = error_of("t,v_l,v_r,v_l\n0,1,1,1\n")

    assert message == "log.csv, line 1, column 'v_l': column appears more than once in the header"


def test_non_numeric_value(in_tmp: Path) -> None:
    """A non-numeric cell is quoted with its file line and column."""
    message = error_of("t,v_l,v_r\n0,1,1\n0.1,abc,1\n")

    assert message == "log.csv, line 3, column 'v_l': 'abc' is not a number"


def test_empty_wheel_speed(in_tmp: Path) -> None:
    """An empty wheel-speed cell is an error."""
    message = error_of("t,v_l,v_r\n0,1,\n")

    assert message == "log.csv, line 2, column 'v_r': empty cell, expected a number"


@pytest.mark.parametrize("cell", ["nan", "NaN", "inf", "-inf", " nan "])
def test_non_finite_wheel_speed(in_tmp: Path, cell: str) -> None:
    """NaN or infinite wheel speeds, also as literal text, are errors."""
    message = error_of(f"t,v_l,v_r\n0,1,1\n0.1,1,{cell}\n")

    assert message == f"log.csv, line 3, column 'v_r': {cell.strip()!r} is not a finite number"


def test_non_finite_angular_speed(in_tmp: Path) -> None:
    """NaN angular wheel speeds are errors, named by their omega column."""
    message = error_of("t,omega_l,omega_r\n0,nan,1\n", wheel_radius=0.3)

    assert message == "log.csv, line 2, column 'omega_l': 'nan' is not a finite number"


def test_nan_time(in_tmp: Path) -> None:
    """A NaN time is an error."""
    message = error_of("t,v_l,v_r\n0,1,1\nnan,1,1\n")

    assert message == "log.csv, line 3, column 't': 'nan' is not a finite number"


def test_time_going_backwards(in_tmp: Path) -> None:
    """Time going backwards names the line and both times."""
    message = error_of("t,v_l,v_r\n0.1,1,1\n0.2,1,1\n0.15,1,1\n")

    assert message.startswith(
        "log.csv, line 4, column 't': time 0.15 s is not after 0.2 s on line 3; "
        "time must strictly increase within a segment"
    )


def test_repeated_time(in_tmp: Path) -> None:
    """A repeated time inside a segment is an error naming the segment."""
    message = error_of("t,v_l,v_r,segment\n0.1,1,1,3\n0.1,1,1,3\n")

    assert message.startswith(
        "log.csv, line 3, column 't': time 0.1 s is not after 0.1 s on line 2"
    )
    assert "(segment 3)" in message


@pytest.mark.parametrize(
    ("cell", "complaint"),
    [
        ("1.5", "'1.5' is not an integer"),
        ("one", "'one' is not an integer"),
        ("", "empty cell, expected an integer"),
        ("99999999999999999999", "'99999999999999999999' is not an integer"),
    ],
)
def test_bad_segment(in_tmp: Path, cell: str, complaint: str) -> None:
    """A segment id must be an int64 integer."""
    message = error_of(f"t,v_l,v_r,segment\n0,1,1,0\n0.1,1,1,{cell}\n")

    assert message == f"log.csv, line 3, column 'segment': {complaint}"


def test_segment_must_be_contiguous(in_tmp: Path) -> None:
    """A segment id may not start again after another segment."""
    message = error_of("t,v_l,v_r,segment\n0,1,1,0\n0,1,1,1\n5,1,1,0\n")

    assert message.startswith("log.csv, line 4, column 'segment': segment 0 starts again")


@pytest.mark.parametrize(
    ("row", "column", "found"), [("0,1", "v_r", 2), ("0,1,1,7", None, 4), ("0", "v_l", 1)]
)
def test_ragged_row(in_tmp: Path, row: str, column: str | None, found: int) -> None:
    """A row with too few or too many cells is an error."""
    message = error_of(f"t,v_l,v_r\n0,1,1\n{row}\n")

    where = "log.csv, line 3" + ("" if column is None else f", column {column!r}")
    assert message == f"{where}: row has {found} cells but the header has 3"


@pytest.mark.parametrize(
    ("header", "missing"), [("x", "y"), ("y", "x"), ("x,y", "yaw"), ("x,yaw", "y")]
)
def test_incomplete_pose_columns(in_tmp: Path, header: str, missing: str) -> None:
    """Pose columns must be all of x, y, yaw, yaw alone, or none."""
    cells = ",".join("0" for _ in header.split(","))
    message = error_of(f"t,v_l,v_r,{header}\n0,1,1,{cells}\n")

    assert message.startswith(f"log.csv, line 1: missing column {missing!r}: pose columns must be")


@pytest.mark.parametrize(
    ("cells", "column", "other"), [("1.0,,0", "y", "x"), (",2.0,0", "x", "y"), ("nan,2,", "x", "y")]
)
def test_position_needs_both_x_and_y(in_tmp: Path, cells: str, column: str, other: str) -> None:
    """Within a row, x and y are given or missing together."""
    message = error_of(f"t,v_l,v_r,x,y,yaw\n0,1,1,,,\n0.1,1,1,{cells}\n")

    assert message == f"log.csv, line 3, column {column!r}: missing while {other} is given; " + (
        "give both or neither"
    )


def test_infinite_pose(in_tmp: Path) -> None:
    """An infinite pose value is an error."""
    message = error_of("t,v_l,v_r,x,y,yaw\n0,1,1,1,inf,0\n")

    assert message == "log.csv, line 2, column 'y': 'inf' is not a finite number"


def test_non_numeric_pose(in_tmp: Path) -> None:
    """A non-numeric pose cell is an error."""
    message = error_of("t,v_l,v_r,yaw\n0,1,1,north\n")

    assert message == "log.csv, line 2, column 'yaw': 'north' is not a number"


def test_empty_terrain_label(in_tmp: Path) -> None:
    """Every row of a terrain column needs a label."""
    message = error_of("t,v_l,v_r,terrain\n0,1,1,grass\n0.1,1,1,  \n")

    assert message.startswith("log.csv, line 3, column 'terrain': empty label")


def test_long_cells_are_shortened_in_messages(in_tmp: Path) -> None:
    """A huge bad cell is shortened so that the message stays one short line."""
    message = error_of(f"t,v_l,v_r\n0,{'z' * 500},1\n")

    assert len(message) < 120 and "...'" in message


# --- speed -------------------------------------------------------------------


def test_written_log_reads_back(tmp_path: Path) -> None:
    """write_wheel_log then read_wheel_log gives the log back (t to 1 us, the rest to 1e-9)."""
    rng = np.random.default_rng(0)
    n = 7
    pose = rng.uniform(-3.0, 3.0, (n, 3))
    pose[1] = np.nan
    pose[2, :2] = np.nan  # heading only
    log = WheelLog(
        t=np.r_[np.arange(4) * 0.1, np.arange(3) * 0.1 + 0.0000004],
        v_l=rng.normal(size=n),
        v_r=rng.normal(size=n),
        pose=pose,
        terrain=np.array(["grass"] * 4 + ["gravel"] * 3),
        segment=np.array([2] * 4 + [5] * 3),
    )
    path = tmp_path / "log.csv"
    write_wheel_log(path, log)
    back = read_wheel_log(path)
    np.testing.assert_allclose(back.t, log.t, atol=5e-7)
    np.testing.assert_allclose(back.v_l, log.v_l, atol=5e-10)
    np.testing.assert_allclose(back.v_r, log.v_r, atol=5e-10)
    np.testing.assert_allclose(back.pose, log.pose, atol=5e-10)
    assert back.terrain.tolist() == log.terrain.tolist()
    assert back.segment.tolist() == log.segment.tolist()
    assert path.read_text().splitlines()[0] == "t,v_l,v_r,x,y,yaw,terrain,segment"


def test_written_log_without_terrain_has_no_terrain_column(tmp_path: Path) -> None:
    """Without labels the file has no terrain column and reads back with terrain None."""
    log = WheelLog(np.arange(3.0), np.ones(3), np.ones(3), np.full((3, 3), np.nan), None,
                   np.zeros(3, dtype=int))  # fmt: skip
    path = tmp_path / "log.csv"
    write_wheel_log(path, log)
    assert path.read_text().splitlines()[:2] == [
        "t,v_l,v_r,x,y,yaw,segment",
        "0.000000,1.000000000,1.000000000,,,,0",
    ]
    assert read_wheel_log(path).terrain is None


def test_writing_into_a_missing_folder_fails_and_leaves_nothing(tmp_path: Path) -> None:
    """The writer is atomic: a missing folder raises FileNotFoundError naming it."""
    log = WheelLog(
        np.zeros(1), np.ones(1), np.ones(1), np.full((1, 3), np.nan), None, np.zeros(1, int)
    )
    with pytest.raises(FileNotFoundError, match="directory does not exist"):
        write_wheel_log(tmp_path / "nope" / "log.csv", log)
    assert list(tmp_path.iterdir()) == []


def test_a_large_log_reads_every_row_and_segment(tmp_path: Path) -> None:
    """100,000 rows, a pose row in ten, 100 segments (its speed: ``python bench/read_wheel_log.py``)."""
    n = 100_000
    k = np.arange(n)
    speeds = np.round(np.sin(0.01 * k), 6)
    pose = np.where(k % 10 == 0, [f"{1e-3 * i},{-1e-3 * i},0.5" for i in k], ",,")
    rows = [
        f"{0.01 * i:.2f},{w},{-w},{p},grass,{i // 1000}"
        for i, w, p in zip(k.tolist(), speeds.tolist(), pose.tolist(), strict=True)
    ]
    path = tmp_path / "big.csv"
    path.write_text("t,omega_l,omega_r,x,y,yaw,terrain,segment\n" + "\n".join(rows) + "\n")
    log = read_wheel_log(path, wheel_radius=0.3)
    assert len(log) == n and np.unique(log.segment).size == n // 1000
    assert np.isfinite(log.pose[:, 0]).sum() == n // 10
    np.testing.assert_allclose(log.v_l, 0.3 * speeds)
    np.testing.assert_allclose(log.v_r, -0.3 * speeds)


# --- real DRIVE logs -----------------------------------------------------------


@pytest.fixture
def drive_files(drive_dir: Path) -> list[Path]:
    """Return the CSV logs of the DRIVE folder (the test is skipped where it is absent)."""
    return sorted(drive_dir.glob("*.csv"))


def raw_columns(path: Path) -> dict[str, list[str]]:
    """Return the raw cells of a CSV file by column, parsed without the reader under test."""
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    return {name: [row[name] for row in rows] for name in rows[0]}


def test_every_drive_log_reads_with_consistent_content(drive_files: list[Path]) -> None:
    """Every DRIVE log reads, and agrees with an independent parse of its cells."""
    files = drive_files
    assert len(files) == 9

    for path in files:
        log = read_wheel_log(path, wheel_radius=0.30)
        raw = raw_columns(path)

        assert len(log) == len(raw["t"]) > 1000, path.name
        np.testing.assert_allclose(log.v_l, 0.30 * np.array(raw["omega_l"], dtype=float))
        np.testing.assert_allclose(log.v_r, 0.30 * np.array(raw["omega_r"], dtype=float))
        assert log.has_position.tolist() == [cell != "" for cell in raw["x"]], path.name
        assert (log.has_position == log.has_yaw).all()
        yaw = log.pose[log.has_yaw, 2]
        assert ((-np.pi < yaw) & (yaw <= np.pi)).all()
        assert log.terrain is not None
        assert set(log.terrain) <= {"grass", "asphalt", "gravel"}
        assert log.source == str(path)


def test_drive_window_files_hold_300_two_second_segments(drive_files: list[Path]) -> None:
    """The window files hold 300 segments of 40 rows, each pose starting at 0."""
    windows = [path for path in drive_files if path.name.startswith("windows_")]
    assert len(windows) == 2

    for path in windows:
        log = read_wheel_log(path, wheel_radius=0.30)
        ids, starts, counts = np.unique(log.segment, return_index=True, return_counts=True)
        assert ids.tolist() == list(range(300))
        assert (counts == 40).all()
        np.testing.assert_allclose(log.t[starts + 39] - log.t[starts], 1.95, atol=1e-6)
        np.testing.assert_array_equal(log.pose[starts], 0.0)  # pose relative to window start
        assert log.terrain is not None
        assert set(log.terrain) == {path.stem.rsplit("_", 1)[1]}


def test_drive_stitched_log_switches_from_grass_to_asphalt_at_113_9_s(drive_dir: Path) -> None:
    """The stitched log turns from grass to asphalt once, at t = 113.9 s."""
    log = read_wheel_log(drive_dir / "stitched_grass_to_asphalt.csv", wheel_radius=0.30)

    assert log.terrain is not None
    switch = np.flatnonzero(log.terrain[1:] != log.terrain[:-1])
    assert switch.size == 1
    assert log.terrain[switch[0]] == "grass" and log.terrain[switch[0] + 1] == "asphalt"
    assert log.t[switch[0] + 1] == pytest.approx(113.9, abs=0.01)
    assert not log.segment.any()


CHUNKED = (
    "t,v_l,v_r,x,y,yaw,terrain,segment\n"
    "0.0,1,1,,,,grass,0\n0.1,1,1,0.5,0.2,0.1,grass,0\n0.2,1,1,,,,sand,0\n"
    "0.0,2,2,,,,sand,1\n0.1,2,2,,,0.3,sand,1\n"
)


@pytest.mark.parametrize("rows", [1, 2, 3])
def test_a_log_read_in_chunks_equals_the_log_read_at_once(monkeypatch, rows):
    whole = read_wheel_log(io.StringIO(CHUNKED))
    monkeypatch.setattr("terrain_odom.io.wheel_log._CHUNK_ROWS", rows)
    chunked = read_wheel_log(io.StringIO(CHUNKED))
    for name in ("t", "v_l", "v_r", "pose", "terrain", "segment"):
        np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name))
    assert chunked.terrain.dtype == whole.terrain.dtype


@pytest.mark.parametrize(
    ("text", "message"),
    [  # the fault lies across the boundary of chunks of 2 rows
        (
            "t,v_l,v_r,segment\n0.0,1,1,0\n0.1,1,1,0\n0.1,1,1,0\n",
            r"line 4, column 't': time 0.1 s is not after 0.1 s on line 3;.*\(segment 0\)",
        ),
        (
            "t,v_l,v_r,segment\n0.0,1,1,0\n0.1,1,1,1\n0.2,1,1,0\n",
            r"line 4, column 'segment': segment 0 starts again after other segments",
        ),
        ("t,v_l,v_r\n0.0,1,1\n0.1,1,1\n0.2,1,inf\n", r"line 4, column 'v_r': 'inf' is not a"),
    ],
)
def test_chunked_faults_across_a_boundary_name_their_line(monkeypatch, text, message):
    monkeypatch.setattr("terrain_odom.io.wheel_log._CHUNK_ROWS", 2)
    with pytest.raises(InputFileError, match=message):
        read_wheel_log(io.StringIO(text))
    monkeypatch.setattr("terrain_odom.io.wheel_log._CHUNK_ROWS", 100)
    with pytest.raises(InputFileError, match=message):  # the same message read at once
        read_wheel_log(io.StringIO(text))


def test_a_real_log_reads_alike_in_small_chunks(drive_dir, monkeypatch):
    path = drive_dir / "warthog_wheels_grass.csv"
    whole = read_wheel_log(path, wheel_radius=0.3)
    monkeypatch.setattr("terrain_odom.io.wheel_log._CHUNK_ROWS", 1000)
    chunked = read_wheel_log(path, wheel_radius=0.3)
    for name in ("t", "v_l", "v_r", "pose", "segment"):
        np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name))

"""A non-editable install runs the quick start from any folder (the default model is package data).

Builds a wheel of this checkout, installs it into a temporary folder with
``pip install --no-deps --target`` and runs both quick starts of the README
(the camera sample with the default classifier, the wheel-log demo) with that
folder first on ``PYTHONPATH``, from another working directory. About 20-40 s.

numba's machine code of the kernels, cached beside this checkout's sources by
the tests that ran before, is copied beside the installed sources (with their
modification times, which the cache is keyed on): the installed package then
loads it instead of compiling every kernel again (~14 s of CPU). numba checks
each cached kernel against the installed function's bytecode, so a kernel that
differs is compiled as before; where nothing is cached yet, all are.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGE = REPO / "src" / "terrain_odom"
SAMPLE = REPO / "sample_images" / "chen2023"


def _pip(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "pip", "--disable-pip-version-check", *args]
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=300)


def _can_build_here() -> bool:
    """Whether this environment's setuptools can make a wheel without an isolated build env."""
    if importlib.util.find_spec("setuptools") is None:
        return False
    if importlib.util.find_spec("wheel") is not None:
        return True
    import setuptools

    major, minor = (int(part) for part in setuptools.__version__.split(".")[:2])
    return (major, minor) >= (70, 1)  # bdist_wheel is part of setuptools from 70.1 on


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Install the package from a wheel into a folder of its own; return the folder."""
    wheels = tmp_path_factory.mktemp("wheels")
    isolation = ["--no-build-isolation"] if _can_build_here() else []
    built = _pip("wheel", "--no-deps", *isolation, "-w", str(wheels), str(REPO))
    if (
        built.returncode != 0
        and not isolation
        and "build dependencies" in built.stdout + built.stderr
    ):
        pytest.skip("no wheel build backend here and none to install (offline)")
    assert built.returncode == 0, built.stdout + built.stderr
    (wheel,) = wheels.glob("terrain_odom-*.whl")
    target = tmp_path_factory.mktemp("site")
    done = _pip("install", "--no-deps", "--no-compile", "--target", str(target), str(wheel))
    assert done.returncode == 0, done.stdout + done.stderr
    _reuse_compiled_kernels(target / "terrain_odom")
    return target


def _reuse_compiled_kernels(installed: Path) -> None:
    """Copy numba's cache files of this checkout beside the same sources in ``installed``."""
    for cache in PACKAGE.rglob("__pycache__/*.nb[ci]"):
        source_dir = cache.parent.parent
        twin_dir = installed / source_dir.relative_to(PACKAGE)
        stem = cache.name.split(".", 1)[0]
        source, twin = source_dir / f"{stem}.py", twin_dir / f"{stem}.py"
        if not (twin.is_file() and twin.read_bytes() == source.read_bytes()):
            continue
        stat = source.stat()
        os.utime(twin, ns=(stat.st_atime_ns, stat.st_mtime_ns))
        (twin_dir / "__pycache__").mkdir(exist_ok=True)
        shutil.copy2(cache, twin_dir / "__pycache__" / cache.name)


def _run(installed: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(installed)}
    command = [sys.executable, "-m", "terrain_odom", *args]
    return subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=120)


def test_the_installed_package_is_the_one_imported(installed, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(installed)}
    code = "import terrain_odom; print(terrain_odom.__file__)"
    found = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert found.returncode == 0, found.stderr
    module = Path(found.stdout.strip()).resolve()
    assert module.is_relative_to(installed.resolve()) and not module.is_relative_to(REPO)
    assert (installed / "terrain_odom" / "models" / "default.npz").is_file()
    assert (installed / "terrain_odom" / "py.typed").is_file()


def test_camera_quick_start_uses_the_packaged_default_classifier(installed, tmp_path):
    done = _run(
        installed,
        tmp_path,
        *("run", "--images", str(SAMPLE), "--wheels", str(SAMPLE / "log.csv"), "--out", "out"),
    )
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "out" / "report.json").read_text(encoding="utf-8"))
    model = Path(report["inputs"]["model"]).resolve()
    assert model == (installed / "terrain_odom" / "models" / "default.npz").resolve()
    assert f"model:      {report['inputs']['model']}" in done.stdout
    assert [change["label"] for change in report["terrain_changes"]] == ["gravel", "grass"]
    assert (tmp_path / "out" / "frames.csv").is_file()


def test_wheel_log_demo_runs_from_another_folder(installed, tmp_path):
    demo = REPO / "examples"
    args = ["--wheels", str(demo / "demo_log.csv"), "--config", str(demo / "demo.yaml")]
    done = _run(installed, tmp_path, "run", *args, "--out", "out-demo")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out-demo" / "trajectory.csv").is_file()

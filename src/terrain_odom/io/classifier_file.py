"""Terrain classifier model files (``.npz``, no pickle) and the default model.

A model file holds the arrays of
:meth:`~terrain_odom.vision.classifier.TerrainClassifier.to_arrays` and a
``metadata`` array, a JSON string: the model's own metadata preceded by the
file's ``format_version`` and followed by ``created`` (UTC) and
``terrain_odom_version``, and, for a model trained with ``train --tune``,
``tuning`` (the grid, every candidate's score and the choice; read back by
:func:`load_tuning`; files without it load as before). :func:`load_classifier` refuses a file whose format,
feature version or feature settings differ from this code's.

The default model of ``terrain-odom run`` ships inside the package
(``terrain_odom/models/default.npz``, found through :mod:`importlib.resources`;
``models/make_default.py`` in the repository regenerates it).
"""

from __future__ import annotations

import datetime
import json
import re
import zipfile
import zlib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from terrain_odom.config.classifier import AUTO, FEATURE_FIELDS, ClassifierConfig
from terrain_odom.config.fields import build_section
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.atomic import write_atomic
from terrain_odom.vision.classifier import MODEL_ARRAYS, TerrainClassifier
from terrain_odom.vision.features import FEATURE_VERSION

__all__ = [
    "MODEL_FORMAT_VERSION",
    "save_classifier",
    "load_classifier",
    "load_tuning",
    "default_classifier_path",
    "default_classifier",
]

MODEL_FORMAT_VERSION = 2
"""Version of the model file layout written by :func:`save_classifier`."""

_ZIP_MAGIC = b"PK\x03\x04"  # a zip archive (an .npz file) starts with a local file header


def save_classifier(
    classifier: TerrainClassifier, path: str | Path, *, tuning: Mapping[str, Any] | None = None
) -> Path:
    """Write a fitted classifier atomically to one ``.npz`` file (no pickle).

    Arrays: those of :meth:`~terrain_odom.vision.classifier.TerrainClassifier.to_arrays`
    and ``metadata``, a JSON string (see the module). The file is written as
    given, even without the ``.npz`` suffix.

    Parameters
    ----------
    classifier : TerrainClassifier
    path : str or Path
    tuning : mapping, optional
        JSON-able record of how the settings were chosen (``train --tune``:
        grid, scores, choice), stored as the metadata's ``tuning``.

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        The classifier is not fitted.
    """
    from terrain_odom import __version__

    path = Path(path)
    arrays, model_meta = classifier.to_arrays()
    metadata = {
        "format_version": MODEL_FORMAT_VERSION,
        **model_meta,
        **({} if tuning is None else {"tuning": dict(tuning)}),
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "terrain_odom_version": __version__,
    }

    def write(handle: BinaryIO) -> None:
        np.savez(
            handle,
            features=arrays["features"],
            labels=arrays["labels"],
            region=arrays["region"],
            scaler_mean=arrays["scaler_mean"],
            scaler_scale=arrays["scaler_scale"],
            metadata=np.array(json.dumps(metadata)),
        )

    write_atomic(path, write)
    return path


def load_classifier(
    path: str | Path, expected: ClassifierConfig | None = None
) -> TerrainClassifier:
    """Read a model written by :func:`save_classifier`.

    Parameters
    ----------
    path : str or Path
    expected : ClassifierConfig, optional
        If given, the model's feature settings
        (:data:`~terrain_odom.config.classifier.FEATURE_FIELDS`) must equal
        these, but for those ``auto`` in ``expected`` (the model records
        what its training chose).

    Raises
    ------
    InputFileError
        The file is missing, not a model or inconsistent, or its format
        version, feature version or feature settings differ from this
        code's or ``expected``'s (the message names the file and both
        values).
    """
    path = Path(path)
    arrays = _read_arrays(path)
    meta = _metadata(path, arrays)
    config = _check_metadata(path, meta, expected)  # versions before the arrays
    _check_arrays(path, config, arrays)
    _check_labels(path, meta, arrays)
    novelty, threshold = meta.get("novelty_distance"), meta.get("min_confidence", 0.0)
    if not (novelty is None or _is_number(novelty, 0.0)) or not _is_number(threshold, 0.0, 1.0):
        raise InputFileError(
            f"{path}: invalid model metadata (novelty_distance {novelty!r}, "
            f"min_confidence {threshold!r})"
        )
    try:
        return TerrainClassifier.from_arrays(
            config, arrays, novelty_distance=novelty, min_confidence=threshold
        )
    except ValueError as exc:
        raise InputFileError(f"{path}: inconsistent model file ({exc})") from None


def _is_number(value: Any, low: float, high: float = float("inf")) -> bool:
    """Whether ``value`` is a JSON number (not a boolean) in ``[low, high]``."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and low <= value <= high


def load_tuning(path: str | Path) -> dict[str, Any] | None:
    """Return the ``tuning`` record of a model file, or ``None`` if it was not tuned.

    Raises
    ------
    InputFileError
        As :func:`load_classifier`.
    """
    path = Path(path)
    meta = _metadata(path, _read_arrays(path))
    tuning = meta.get("tuning")
    if tuning is not None and not isinstance(tuning, dict):
        raise InputFileError(f"{path}: invalid model metadata (tuning is not a mapping)")
    return tuning


def _read_arrays(path: Path) -> dict[str, Any]:
    """Return the members of an ``.npz`` file: arrays, or bytes for members that are not.

    Raises
    ------
    InputFileError
        The file is missing, unreadable, not a zip archive, damaged or truncated,
        or holds object arrays (which are never unpickled).
    """
    try:
        with path.open("rb") as handle:
            magic = handle.read(len(_ZIP_MAGIC))
            handle.seek(0)
            if zipfile.is_zipfile(handle):
                with np.load(handle, allow_pickle=False) as data:
                    return {name: data[name] for name in data.files}
    except FileNotFoundError:
        raise InputFileError(f"{path}: model file not found") from None
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read model file ({exc.strerror or exc})") from None
    except (zipfile.BadZipFile, EOFError, zlib.error, NotImplementedError, RuntimeError) as exc:
        raise InputFileError(f"{path}: damaged model file ({exc})") from None
    except ValueError:  # numpy's message would suggest unpickling: never for a model
        raise InputFileError(
            f"{path}: not a terrain-odom model file (a member is not a plain .npy array)"
        ) from None
    if magic == _ZIP_MAGIC:
        raise InputFileError(
            f"{path}: truncated or damaged model file (an .npz archive without its end: "
            "an interrupted copy or download?)"
        )
    raise InputFileError(
        f"{path}: not a terrain-odom model file (not an .npz archive); "
        "give a model written by 'terrain-odom train'"
    )


def _metadata(path: Path, arrays: dict[str, Any]) -> dict[str, Any]:
    """Return the decoded ``metadata`` array of a model file."""
    raw = arrays.get("metadata")
    if not isinstance(raw, np.ndarray):
        raise InputFileError(f"{path}: not a terrain-odom model file (no metadata)")
    try:
        meta = json.loads(str(raw))
    except (json.JSONDecodeError, RecursionError):
        meta = None
    if not isinstance(meta, dict):
        raise InputFileError(f"{path}: not a terrain-odom model file (bad metadata)")
    return meta


def _check_arrays(path: Path, config: ClassifierConfig, arrays: dict[str, Any]) -> None:
    """Raise unless the model's arrays have the types and shapes a model of ``config`` has."""
    missing = set(MODEL_ARRAYS) - {k for k, v in arrays.items() if isinstance(v, np.ndarray)}
    if missing:
        raise InputFileError(f"{path}: not a terrain-odom model file (no {sorted(missing)})")
    features = arrays["features"]
    if features.dtype.kind not in "fiu" or features.ndim != 2 or not features.size:
        raise InputFileError(
            f"{path}: inconsistent model file: features are {features.dtype} of shape "
            f"{features.shape}, not numbers of shape (samples, features)"
        )
    width = features.shape[1]
    scaled = (width,) if config.scale else (0,)  # empty without scaling
    for name in ("scaler_mean", "scaler_scale"):
        scaler = arrays[name]
        if scaler.dtype.kind not in "fiu" or scaler.shape != scaled:
            raise InputFileError(
                f"{path}: inconsistent model file: features and scaler disagree ({name} is "
                f"{scaler.dtype} of shape {scaler.shape}; {width} feature columns "
                f"{'need' if config.scale else 'without scaling need'} numbers of shape {scaled}); "
                "retrain the model with 'terrain-odom train'"
            )
    if not all(np.isfinite(arrays[n]).all() for n in ("features", "scaler_mean", "scaler_scale")):
        raise InputFileError(f"{path}: inconsistent model file: non-finite features or scaler")
    if not (arrays["scaler_scale"] > 0).all():
        raise InputFileError(f"{path}: inconsistent model file: a scaler_scale is not > 0")


_LABEL = re.compile(r"[^./\\\x00-\x1f\x7f][^/\\\x00-\x1f\x7f]*")
"""A terrain label: a class folder's name (no path separator, control character, leading dot)."""


def _check_labels(path: Path, meta: dict[str, Any], arrays: dict[str, Any]) -> None:
    """Raise unless the labels are text, one per sample, folder names, and the metadata's classes.

    Raises
    ------
    InputFileError
        Integer labels, a label like ``carpet/../x``, a count that differs
        from the samples', or metadata ``classes`` that contradict the labels.
    """
    labels, samples = arrays["labels"], len(arrays["features"])
    if labels.dtype.kind != "U" or labels.shape != (samples,):
        raise InputFileError(
            f"{path}: inconsistent model file: labels are {labels.dtype} of shape "
            f"{labels.shape}, not {samples} terrain names (text)"
        )
    classes = sorted(set(labels.tolist()))
    bad = next((c for c in classes if not _LABEL.fullmatch(c)), None)
    if bad is not None:
        raise InputFileError(
            f"{path}: inconsistent model file: label {bad!r} is no terrain name (a class "
            "folder's name: no '/', no control character, not starting with '.')"
        )
    claimed = meta.get("classes")
    if claimed is not None and (
        not isinstance(claimed, list) or sorted(map(str, claimed)) != classes
    ):
        raise InputFileError(
            f"{path}: inconsistent model file: its metadata lists classes {claimed!r} but "
            f"its labels are {classes}"
        )


def _check_metadata(
    path: Path, meta: dict[str, Any], expected: ClassifierConfig | None
) -> ClassifierConfig:
    """Return the model's configuration, or raise if it does not match this code."""
    for key, ours in (
        ("format_version", MODEL_FORMAT_VERSION),
        ("feature_version", FEATURE_VERSION),
    ):
        if meta.get(key) != ours:
            raise InputFileError(
                f"{path}: model {key} is {meta.get(key)!r} but this terrain-odom uses {ours}; "
                "retrain the model with 'terrain-odom train'"
            )
    try:
        config: ClassifierConfig = build_section(ClassifierConfig(), meta["config"], "config")
    except (ConfigError, KeyError) as exc:
        raise InputFileError(f"{path}: invalid model metadata ({exc})") from None
    if expected is not None:
        for name in FEATURE_FIELDS:
            theirs, ours = getattr(config, name), getattr(expected, name)
            if theirs != ours and ours != AUTO:  # auto: whatever the training chose
                raise InputFileError(
                    f"{path}: model was trained with {name}={theirs!r} but the configuration "
                    f"asks for {name}={ours!r}; retrain the model or change the configuration"
                )
    return config


def default_classifier_path() -> Path:
    """Return where the default classifier is: ``models/default.npz`` inside the package.

    Found through :mod:`importlib.resources`, so an installed package (editable
    or not) finds it wherever it is.
    """
    return Path(str(resources.files("terrain_odom") / "models" / "default.npz"))


def default_classifier(path: Path | None = None) -> Path:
    """Return the default classifier's file, or raise if it is missing.

    Parameters
    ----------
    path : Path, optional
        Where it should be (default: :func:`default_classifier_path`).

    Raises
    ------
    InputFileError
        The default classifier is not there (an installation without its package data).
    """
    path = default_classifier_path() if path is None else path
    if not path.is_file():
        raise InputFileError(
            f"no --classifier given and the default classifier {path} is missing (it ships "
            "as package data of terrain_odom): pass --classifier FILE"
        )
    return path

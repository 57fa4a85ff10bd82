"""Issue 24: a model file whose labels or metadata contradict themselves is one line."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.errors import InputFileError
from terrain_odom.io.classifier_file import default_classifier_path, load_classifier


def _model(tmp_path: Path, change) -> Path:  # type: ignore[no-untyped-def]
    """Write the default model with ``change(arrays, metadata)`` applied, as a new file."""
    with np.load(default_classifier_path(), allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    meta = json.loads(str(arrays["metadata"]))
    change(arrays, meta)
    arrays["metadata"] = np.array(json.dumps(meta))
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    path = tmp_path / "model.npz"
    path.write_bytes(buffer.getvalue())
    return path


def _relabel(arrays: dict, mapping) -> None:  # type: ignore[no-untyped-def]
    arrays["labels"] = np.array([mapping(label) for label in arrays["labels"].tolist()])


def test_the_default_classifier_passes(tmp_path: Path) -> None:
    assert load_classifier(_model(tmp_path, lambda arrays, meta: None)).classes


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (lambda a, m: _relabel(a, lambda s: len(s)), "labels are int64 of shape"),
        (lambda a, m: _relabel(a, lambda s: f"{s}/../x"), "/../x' is no terrain name"),
        (lambda a, m: _relabel(a, lambda s: ".hidden"), "label '.hidden' is no terrain name"),
        (lambda a, m: _relabel(a, lambda s: "a\nb"), "label 'a\\nb' is no terrain name"),
        (lambda a, m: a.update(labels=a["labels"][:-1]), "terrain names (text)"),
        (lambda a, m: m.update(classes=["grass", "snow"]), "its metadata lists classes"),
        (lambda a, m: m.update(classes="grass"), "its metadata lists classes 'grass'"),
    ],
)
def test_labels_contradicting_the_model_are_refused(change, expected: str, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    path = _model(tmp_path, change)
    before = path.read_bytes()
    with pytest.raises(InputFileError, match="inconsistent model file") as caught:
        load_classifier(path)
    assert expected in str(caught.value) and "\n" not in str(caught.value)
    assert path.read_bytes() == before

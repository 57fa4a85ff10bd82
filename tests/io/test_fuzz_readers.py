"""Property-based tests of the file readers of :mod:`terrain_odom.io`.

Whatever bytes a file holds, :func:`~terrain_odom.io.wheel_log.read_wheel_log`,
:func:`~terrain_odom.io.classifier_file.load_classifier` and
:func:`~terrain_odom.io.params.read_params` give a parsed result or the
project's own input error (:class:`~terrain_odom.errors.TerrainOdomError`),
never another exception: the command line prints the latter as one line.
"""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import TerrainOdomError
from terrain_odom.io.classifier_file import load_classifier, save_classifier
from terrain_odom.io.params import read_params
from terrain_odom.io.wheel_log import read_wheel_log
from terrain_odom.records import WheelLog
from terrain_odom.vision.classifier import MODEL_ARRAYS, TerrainClassifier

FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])

_COLUMNS = ("t", "v_l", "v_r", "omega_l", "omega_r", "x", "y", "yaw", "terrain", "segment")
_CELLS = st.one_of(
    st.sampled_from(["", " ", "nan", "inf", "-inf", "1e400", "0x1p3", "1_0", "٣", "grass"]),
    st.integers(-(2**70), 2**70).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=5),
)


@st.composite
def _csv_like(draw: st.DrawFn) -> bytes:
    """Draw a CSV text with wheel-log columns and random cells (to get past the header)."""
    header = draw(st.lists(st.sampled_from(_COLUMNS), min_size=1, max_size=8))
    rows = draw(st.lists(st.lists(_CELLS, min_size=0, max_size=len(header) + 1), max_size=6))
    lines = [",".join(header), *(",".join(row) for row in rows)]
    return "\n".join(lines).encode("utf-8", "surrogatepass")


def _read_or_refuse(read, path: Path, data: bytes):  # noqa: ANN001, ANN202 (any reader)
    """Write ``data`` to ``path`` and read it; the project's own error is an answer too."""
    path.write_bytes(data)
    try:
        return read(path)
    except TerrainOdomError as exc:
        assert str(exc) and "\n" not in str(exc)
        return exc


@FUZZ
@given(
    data=st.one_of(st.binary(max_size=300), _csv_like()),
    radius=st.sampled_from([None, 0.3, 0.0, float("nan")]),
)
def test_wheel_log_reader_parses_or_refuses_any_bytes(tmp_path_factory, data, radius):
    result = _read_or_refuse(
        lambda p: read_wheel_log(p, wheel_radius=radius),
        tmp_path_factory.getbasetemp() / "log.csv",
        data,
    )
    assert isinstance(result, (WheelLog, TerrainOdomError))


@FUZZ
@given(data=st.binary(max_size=300))
def test_parameter_reader_parses_or_refuses_any_bytes(tmp_path_factory, data):
    _read_or_refuse(read_params, tmp_path_factory.getbasetemp() / "params.yaml", data)


# --- model files ------------------------------------------------------------------


@pytest.fixture(scope="module")
def model_bytes(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    """Return a small valid model file (5 features, 8 rows, two classes)."""
    features = np.random.default_rng(0).normal(size=(8, 5))
    model = TerrainClassifier(ClassifierConfig(k=3)).fit(features, list("aaaabbbb"))
    return save_classifier(model, tmp_path_factory.mktemp("model") / "m.npz").read_bytes()


def _model_arrays(data: bytes) -> dict[str, np.ndarray]:
    with np.load(io.BytesIO(data), allow_pickle=False) as npz:
        return {name: npz[name] for name in npz.files}


def _npz(arrays: dict[str, np.ndarray]) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


@FUZZ
@given(data=st.binary(max_size=300))
def test_model_loader_parses_or_refuses_any_bytes(tmp_path_factory, data):
    result = _read_or_refuse(load_classifier, tmp_path_factory.getbasetemp() / "m.npz", data)
    assert isinstance(result, TerrainOdomError)  # random bytes are never a model
    assert "allow_pickle" not in str(result) and "pickle" not in str(result)


@FUZZ
@given(cut=st.integers(0, 10_000), flips=st.lists(st.tuples(st.integers(0), st.integers(1, 255))))
def test_model_loader_refuses_truncated_or_damaged_models(
    tmp_path_factory, model_bytes, cut, flips
):
    data = bytearray(model_bytes[: len(model_bytes) - cut % len(model_bytes)])
    for at, mask in flips:
        if data:
            data[at % len(data)] ^= mask
    result = _read_or_refuse(load_classifier, tmp_path_factory.getbasetemp() / "m.npz", bytes(data))
    assert isinstance(result, (TerrainClassifier, TerrainOdomError))


_ANY_ARRAY = hnp.arrays(
    dtype=st.one_of(hnp.scalar_dtypes(), hnp.unicode_string_dtypes(max_len=3)),
    shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=6),
)


@FUZZ
@given(name=st.sampled_from([*MODEL_ARRAYS, "metadata"]), array=_ANY_ARRAY)
def test_model_loader_refuses_models_whose_arrays_disagree(
    tmp_path_factory, model_bytes, name, array
):
    arrays = {**_model_arrays(model_bytes), name: array}
    result = _read_or_refuse(
        load_classifier, tmp_path_factory.getbasetemp() / "m.npz", _npz(arrays)
    )
    assert isinstance(result, (TerrainClassifier, TerrainOdomError))


_JSON = st.recursive(
    st.one_of(
        st.none(),
        st.booleans(),
        st.integers(-(2**70), 2**70),
        st.floats(allow_nan=False),
        st.sampled_from(["sfta", "sfta+lab", "distance"]),
        st.text(max_size=4),
    ),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=3)
    ),
    max_leaves=6,
)


@FUZZ
@given(
    config=st.one_of(
        st.dictionaries(st.sampled_from(["features", "n_t", "k", "scale", "tile_size"]), _JSON),
        _JSON,
    )
)
def test_model_loader_refuses_any_metadata_config(tmp_path_factory, model_bytes, config):
    arrays = _model_arrays(model_bytes)
    meta = {**json.loads(str(arrays["metadata"])), "config": config}
    arrays["metadata"] = np.array(json.dumps(meta))
    result = _read_or_refuse(
        load_classifier, tmp_path_factory.getbasetemp() / "m.npz", _npz(arrays)
    )
    assert isinstance(result, (TerrainClassifier, TerrainOdomError))


def test_a_zip_that_is_not_a_model_is_refused(tmp_path):
    path = tmp_path / "notes.npz"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("metadata.npy", b"not an array")
    with pytest.raises(TerrainOdomError, match="not a terrain-odom model file"):
        load_classifier(path)

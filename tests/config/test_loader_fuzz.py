"""Property-based tests of the configuration loaders (:mod:`terrain_odom.config.loader`).

Whatever a YAML file holds, :func:`~terrain_odom.config.load_config` and
:func:`~terrain_odom.config.loader.load_classifier_config` give a
configuration or a :class:`~terrain_odom.errors.ConfigError`, never another
exception.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrain_odom.config import Config, load_classifier_config, load_config
from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import ConfigError

FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])

_SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(),
    st.sampled_from(["auto", "sfta", "arrival", "distance", "1e400", "2024-13-45"]),
    st.text(max_size=4),
)
_VALUES = st.recursive(
    _SCALARS,
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=2)
    ),
    max_leaves=5,
)
_YAML_SNIPPETS = st.sampled_from(
    [
        "a: 2024-13-45",
        "a: !!float abc",
        "a: !!binary x",
        "<<: 1",
        "? [a]\n: 1",
        "a: !!python/object:os.system x",
        "a: &x [*x]",
        "[" * 400,
        "- " * 400,
        "\t",
        "%YAML 9.9\n---\n",
        "a: 1\na: 2",
    ]
)


def _mapping_of(default: Any) -> st.SearchStrategy[dict[str, Any]]:
    """Draw mappings shaped like the dataclass ``default``: its keys, random values."""
    fields = {}
    for f in dataclasses.fields(default):
        value = getattr(default, f.name)
        fields[f.name] = (
            _mapping_of(value) if dataclasses.is_dataclass(value) else st.just(value) | _VALUES
        )
    return st.fixed_dictionaries({}, optional=fields)


def _as_yaml(data: Any) -> bytes:
    return yaml.safe_dump(data, allow_unicode=True).encode("utf-8")


_CONFIG_FILES = st.one_of(
    st.binary(max_size=200),
    _YAML_SNIPPETS.map(str.encode),
    _mapping_of(Config()).map(_as_yaml),
    _VALUES.map(_as_yaml),
)


def _load_or_refuse(load, path: Path, data: bytes):  # noqa: ANN001, ANN202 (any loader)
    path.write_bytes(data)
    try:
        return load(path)
    except ConfigError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
        return exc


@FUZZ
@given(data=_CONFIG_FILES)
def test_config_loader_gives_a_config_or_a_config_error(tmp_path_factory, data):
    result = _load_or_refuse(load_config, tmp_path_factory.getbasetemp() / "robot.yaml", data)
    assert isinstance(result, (Config, ConfigError))


@FUZZ
@given(data=st.one_of(_CONFIG_FILES, _mapping_of(ClassifierConfig()).map(_as_yaml)))
def test_classifier_config_loader_gives_a_config_or_a_config_error(tmp_path_factory, data):
    result = _load_or_refuse(
        load_classifier_config, tmp_path_factory.getbasetemp() / "classifier.yaml", data
    )
    assert isinstance(result, (ClassifierConfig, ConfigError))


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("".join(" " * i + "-\n" for i in range(3000)), "nested too deeply"),
        ("a: 2024-13-45\n", "not valid YAML (month must be in 1..12)"),
    ],
)
def test_yaml_a_parser_cannot_build_is_one_config_error(tmp_path, text, problem):
    path = tmp_path / "c.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match=re.escape(problem)):
        load_config(path)


def test_a_binary_file_is_not_yaml(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\xff")
    with pytest.raises(ConfigError, match=r"c\.yaml: not a UTF-8 text file .*YAML config file"):
        load_config(path)

"""Training horizons: what ``parse_horizon`` and ``Horizon`` accept, refuse, and say."""

from __future__ import annotations

import math
import re

import pytest

from terrain_odom.fitting import Horizon, parse_horizon


def test_a_bare_number_is_metres():
    assert parse_horizon(3) == Horizon(3.0, "m")
    assert parse_horizon(0.25) == Horizon(0.25, "m")
    assert parse_horizon("2") == Horizon(2.0, "m")
    assert str(parse_horizon("1.5 s")) == "1.5s"


def test_horizons_below_one_are_accepted():
    assert parse_horizon("0.5m") == Horizon(0.5, "m")
    assert parse_horizon("1") == Horizon(1.0, "m")


@pytest.mark.parametrize("value", [-1.0, 0.0, math.inf, math.nan])
def test_a_horizon_must_be_positive_and_finite(value):
    with pytest.raises(ValueError, match=f"^horizon must be a positive number, got {value}$"):
        Horizon(value, "m")


def test_a_horizon_unit_is_metres_or_seconds():
    message = "horizon unit must be 'm' or 's', got 'km'"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        Horizon(2.0, "km")

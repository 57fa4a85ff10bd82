"""Metadata for configuration dataclass fields (no imports, so any module can use it).

A float field of a configuration dataclass must be > 0 unless its metadata
says otherwise::

    offset: float = field(default=0.0, metadata=SIGNED)
"""

from __future__ import annotations

__all__ = ["SIGNED", "NON_NEGATIVE"]

SIGNED = {"range": "signed"}
"""Any finite value."""

NON_NEGATIVE = {"range": "non-negative"}
"""Finite and >= 0."""

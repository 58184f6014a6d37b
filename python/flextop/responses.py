"""The responses the engine computes, read from it: names, how each is written, what it
measures (with units) and whether a limit on it bounds its peak.

The engine holds one file per family of responses and registers each in one table; this
module is its Python face, so that documentation, the command line and the problems'
rules never repeat the list.
"""

from __future__ import annotations

from dataclasses import dataclass

from . import _core


@dataclass(frozen=True)
class ResponseKind:
    """One kind of response: ``syntax`` has arguments in capitals and optional parts in
    brackets; ``peak``: a limit on it bounds its peak (Le et al.'s normalization); ``unit``
    in SI ("1" for a ratio)."""

    name: str
    syntax: str
    doc: str
    peak: bool
    unit: str


KINDS: tuple[ResponseKind, ...] = tuple(ResponseKind(*k) for k in _core.response_kinds())
"""Every kind, in the engine's order."""

NAMES: tuple[str, ...] = tuple(k.name for k in KINDS)
"""Every response name (the part before the first ``:``)."""

PEAK_LIMITED: tuple[str, ...] = tuple(k.name for k in KINDS if k.peak)
"""Responses that are means of point values reported with their peaks, whose limits bound
the peak: stresses, shear, buckling, a drive's torque and a joint's reaction."""


def unit(response: str) -> str:
    """The unit of ``response`` (a name with or without its arguments, ``tip_deflection:tip``),
    "" for a name the engine does not know."""
    kind = response.split(":", 1)[0]
    return next((k.unit for k in KINDS if k.name == kind), "")


def label(response: str) -> str:
    """``response`` with its unit for an axis: ``tip_deflection (m²)``."""
    u = unit(response)
    return f"{response} ({u})" if u and u != "1" else response


def describe(indent: str = "") -> str:
    """The list of responses as reStructuredText bullets, one per kind."""
    return "\n".join(f"{indent}- ``{k.syntax}``: {k.doc}." for k in KINDS)

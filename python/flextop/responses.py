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
    in SI ("1" for a ratio); ``planar``: a planar scene offers it; ``spatial``: how a
    spatial scene writes it, ``None`` where it does not offer it. A name means the same on
    both."""

    name: str
    syntax: str
    doc: str
    peak: bool
    unit: str
    planar: bool
    spatial: str | None


KINDS: tuple[ResponseKind, ...] = tuple(ResponseKind(*k) for k in _core.response_kinds())
"""Every kind of either engine, in the engine's order."""

NAMES: tuple[str, ...] = tuple(k.name for k in KINDS if k.planar)
"""Every response name of a planar scene (the part before the first ``:``)."""

SPATIAL_NAMES: tuple[str, ...] = tuple(k.name for k in KINDS if k.spatial is not None)
"""Every response name of a spatial scene."""

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


def describe(indent: str = "", spatial: bool = False) -> str:
    """The list of a planar scene's responses (a spatial scene's with ``spatial``) as
    reStructuredText bullets, one per kind."""
    listed = [(k.spatial, k.doc) for k in KINDS if k.spatial] if spatial else [(k.syntax, k.doc) for k in KINDS if k.planar]
    return "\n".join(f"{indent}- ``{syntax}``: {doc}." for syntax, doc in listed)

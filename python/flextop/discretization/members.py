"""A scene's continuum members refined for an error estimate: each member's cells split
``factor × factor`` times more (the member's ``split``, one density to a cell still), and
what holds a member's edge carried along the nodes the split puts on it, so that the
refined scene is the same body, supported and tied alike, on a finer mesh.

A member's nodes are named by their place in cells (``plate[3,1]``, ``plate[7/2,1]``), the
same point by the same name at every split. Two nodes listed one after the other in a ring,
or carrying a pin or roller of the same kind and settings, that are neighbours on the
member's mesh (one element apart along a grid line) mark a stretch of edge the ring or the
supports hold: the nodes the split puts between them join the ring (averaging weights
interpolated linearly) and get the same support. Loads and point masses stay on their nodes,
points as the scene gives them.
"""

from __future__ import annotations

import re
from fractions import Fraction

NODE = re.compile(r"^(?P<member>.+)\[(?P<i>\d+(?:/\d+)?),(?P<j>\d+(?:/\d+)?)\]$")
"""A member node's name: ``NAME[i,j]``, each place whole or a fraction ``a/b``."""

_Place = tuple[str, Fraction, Fraction]


def split_members(spec: dict, factor: int) -> None:
    """Refines, in place, every member of the scene dict ``spec`` by ``factor`` (its cells'
    elements ``factor`` times more along each side), its rings and edge supports carried
    along (module docstring)."""
    splits = {m["name"]: int(m.get("split", 1)) for m in spec.get("members", [])}
    if factor == 1 or not splits:
        return
    for m in spec["members"]:
        m["split"] = splits[m["name"]] * factor
    for ring in spec.get("rings", []):
        _refine_ring(ring, splits, factor)
    if spec.get("joints"):
        spec["joints"] = _refined_supports(spec["joints"], splits, factor)


def _place(name: str, splits: dict[str, int]) -> _Place | None:
    """The member and place in cells of the node ``name``, ``None`` if it is no member's."""
    match = NODE.match(name)
    if match is None or match["member"] not in splits:
        return None
    return match["member"], Fraction(match["i"]), Fraction(match["j"])


def _name(member: str, i: Fraction, j: Fraction) -> str:
    """The name of the member node at place ``(i, j)`` (:mod:`flextop`'s Rust names it so)."""
    return f"{member}[{i},{j}]"


def _between(a: str, b: str, splits: dict[str, int], factor: int) -> list[str]:
    """The nodes the split by ``factor`` puts between nodes ``a`` and ``b``, in order from
    ``a``, if they are neighbours on a member's mesh; none otherwise."""
    pa, pb = _place(a, splits), _place(b, splits)
    if pa is None or pb is None or pa[0] != pb[0]:
        return []
    member, step = pa[0], Fraction(1, splits[pa[0]])
    di, dj = pb[1] - pa[1], pb[2] - pa[2]
    if sorted((abs(di), abs(dj))) != [0, step]:
        return []
    return [_name(member, pa[1] + di * Fraction(k, factor), pa[2] + dj * Fraction(k, factor)) for k in range(1, factor)]


def _refine_ring(ring: dict, splits: dict[str, int], factor: int) -> None:
    """The ring's nodes with those the split puts between neighbours listed one after the
    other (a loop of three or more nodes: its last and first too), and their weights
    interpolated linearly."""
    nodes, weights = list(ring["nodes"]), ring.get("weights")
    closed = len(nodes) > 2
    refined_nodes, refined_weights = [], []
    for k, a in enumerate(nodes):
        refined_nodes.append(a)
        if weights is not None:
            refined_weights.append(weights[k])
        if k + 1 == len(nodes) and not closed:
            break
        following = (k + 1) % len(nodes)
        inner = _between(a, nodes[following], splits, factor)
        refined_nodes += inner
        if weights is not None and inner:
            wa, wb = weights[k], weights[following]
            refined_weights += [wa + (wb - wa) * t / factor for t in range(1, factor)]
    ring["nodes"] = refined_nodes
    if weights is not None:
        ring["weights"] = refined_weights


SUPPORTS = ("pin", "roller")
"""The joints on one node that hold an edge where they stand on neighbouring nodes."""


def _refined_supports(joints: list[dict], splits: dict[str, int], factor: int) -> list[dict]:
    """``joints`` with a copy of every undriven pin or roller on each node the split puts
    between it and a neighbouring member node (right or above) that carries the same
    support (kind and axis), named after it and its node: ``wall0@plate[0,1/2]``."""
    held = {joint["node"]: joint for joint in joints
            if joint.get("kind") in SUPPORTS and "node" in joint and joint.get("drive") is None}
    added = []
    for node, joint in held.items():
        place = _place(node, splits)
        if place is None:
            continue
        member, i, j = place
        step = Fraction(1, splits[member])
        for neighbour in (_name(member, i + step, j), _name(member, i, j + step)):
            other = held.get(neighbour)
            if other is not None and (other["kind"], other.get("axis")) == (joint["kind"], joint.get("axis")):
                added += [{**joint, "name": f"{joint['name']}@{between}", "node": between}
                          for between in _between(node, neighbour, splits, factor)]
    return joints + added

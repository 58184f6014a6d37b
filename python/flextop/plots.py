"""Figures of topology optimization: density maps, convergence histories, tip errors and
animations of the moving mechanism.

Every function builds its own :class:`matplotlib.figure.Figure` (no pyplot state, so it
is safe headless and from threads), returns it, and writes a PNG at 150 dpi when given a
``path``. Bars are always drawn as the straight segment between their end nodes, whatever
their ``split``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any, Sequence

import matplotlib
import numpy as np
from matplotlib.animation import PillowWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import Colormap, Normalize
from matplotlib.figure import Figure

from . import responses
from .errors import SettingsError
from .io.export import frame_indices
from .results import Results
from .simulation import Simulation

__all__ = ["animate", "magnified_positions", "plot_deformed", "plot_design", "plot_history", "plot_paths", "plot_spatial_design",
           "plot_spatial_paths", "plot_tip_error"]

#: Colormap of the density maps: white for x_min (void) to black for full density, as the
#: topology-optimization literature draws them.
DEFAULT_CMAP = "gray_r"
#: Line widths (points) of a bar at density x_min and at full density: thin enough that the
#: bars meeting at a node of a slender link stay apart.
WIDTHS = (0.3, 2.5)
#: Opacity of bars drawn below ``min_density``.
FAINT_ALPHA = 0.15
DPI = 150


def _bar_style(sim: Simulation, x: Any, cmap: str | Colormap, min_density: float | None,
               widths: tuple[float, float] = WIDTHS) -> tuple[np.ndarray, np.ndarray, ScalarMappable]:
    """Line widths (linear in density from ``widths[0]`` at x_min to ``widths[1]`` at 1)
    and RGBA colours (``cmap`` over [x_min, 1], faint below ``min_density``) of every bar,
    and the mappable for a colorbar."""
    rho = sim.bar_densities(x)
    colormap = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
    mappable = ScalarMappable(Normalize(vmin=sim.x_min, vmax=1.0), colormap)
    t = np.clip(mappable.norm(rho), 0.0, 1.0)
    lw = widths[0] + (widths[1] - widths[0]) * t
    colors = mappable.to_rgba(rho)
    if min_density is not None:
        colors[rho < min_density, 3] = FAINT_ALPHA
    return lw, colors, mappable


def _segments(sim: Simulation, positions: np.ndarray) -> np.ndarray:
    """Bar segments ``(n_bars, 2, 2)``: the positions of each bar's two end nodes."""
    return np.asarray(positions)[np.asarray(sim.bars.nodes, dtype=int)]


def _save(fig: Figure, path: str | os.PathLike | None) -> Figure:
    if path is not None:
        fig.savefig(path, dpi=DPI)
    return fig


def _new_figure(**kwargs: Any) -> Figure:
    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def _design_layout(positions: np.ndarray) -> tuple[tuple[float, float], str]:
    """Figure size (in) fitting the structure's bounding box, and where the colorbar goes:
    below a wide structure, right of a tall one."""
    width, height = np.ptp(positions, axis=0) + 1e-12
    aspect = float(np.clip(height / width, 0.1, 4.0))
    if aspect <= 0.5:
        return (8.0, 6.5 * aspect + 1.8), "bottom"
    if aspect <= 1.0:
        return (8.0, 6.5 * aspect + 1.2), "right"
    return (6.0 / aspect + 2.0, 7.0), "right"


def plot_design(sim: Simulation, x: Any, *, positions: np.ndarray | None = None, ax: Any = None,
                title: str | None = None, path: str | os.PathLike | None = None,
                min_density: float | None = None, cmap: str | Colormap = DEFAULT_CMAP,
                by_component: bool | None = None) -> Figure:
    """Density map of design ``x`` (paper Figs. 4, 7, 8).

    Each bar is a straight line between its end nodes, whose width grows linearly with its
    density and whose colour follows ``cmap`` from ``sim.x_min`` to 1; a colorbar labelled
    "Density" gives the scale. Fixed bars are drawn at density 1, and bars below
    ``min_density`` faint (default: 1.5 ``x_min``, the voids; 0 draws every bar alike).
    Equal aspect, axes in metres.

    ``by_component`` (the default for a scene of several components, drawn into a new
    figure at the reference configuration): one panel per component, each in its own frame
    (its long axis horizontal, from its own origin), so that links that overlap in the
    scene's pose are seen apart. Otherwise one panel at ``positions`` (``(n_nodes, 2)``,
    the reference configuration by default), into ``ax`` if given.
    """
    faint = 1.5 * sim.x_min if min_density is None else (min_density or None)
    several = len(sim.components) > 1
    if by_component or (by_component is None and several and positions is None and ax is None):
        return _save(_design_by_component(sim, x, title, faint, cmap), path)
    positions = _positions(sim, positions)
    figsize, location = _design_layout(positions)
    if ax is None:
        fig = _new_figure(figsize=figsize, layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    mappable = _draw_bars(ax, sim, x, _segments(sim, positions), np.ones(len(sim.bars), bool), faint, cmap)
    _draw_cells(ax, sim, x, positions, np.ones(len(sim.cell_densities()), bool), cmap)
    _draw_supports(ax, sim, positions, np.ones(len(positions), bool))
    if title is not None:
        ax.set_title(title)
    fig.colorbar(mappable, ax=ax, label="Density", location=location, shrink=0.8,
                 aspect=30 if location == "bottom" else 20)
    return _save(fig, path)


def plot_spatial_design(sim: Any, x: Any, *, q: Any = None, view: tuple[float, float] = (25.0, -60.0),
                        min_density: float | None = None, cmap: str | Colormap = DEFAULT_CMAP,
                        title: str | None = None, path: str | os.PathLike | None = None) -> Figure:
    """Density map of design ``x`` of a :class:`~flextop.spatial.SpatialSimulation`'s beams
    and bars in 3D, seen from ``view`` (elevation and azimuth, degrees).

    As :func:`plot_design`: each beam element or bar a line whose width grows with its density
    and whose colour follows ``cmap`` from ``x_min`` to 1 (fixed ones at 1), those below
    ``min_density`` faint (default 1.5 ``x_min``; 0 draws all alike); bodies as black dots.
    At configuration ``q`` (seven numbers per node, e.g. a row of ``SpatialResults.q``; the
    initial one by default). Equal axes in metres."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    layout = sim.layout
    rho = layout.line_densities(sim.design(x))
    config = np.asarray(sim.model.initial_q if q is None else q, dtype=float)
    if config.shape != (7 * len(layout.nodes_in_order),) or not np.all(np.isfinite(config)):
        raise SettingsError(f"q: expected {7 * len(layout.nodes_in_order)} finite numbers (seven per node), "
                            f"got shape {config.shape}")
    points = config.reshape(-1, 7)[:, :3]
    segments = points[np.asarray(layout.lines, dtype=int).reshape(-1, 2)]
    colormap = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
    mappable = ScalarMappable(Normalize(vmin=sim.x_min, vmax=1.0), colormap)
    colors = mappable.to_rgba(rho)
    faint = 1.5 * sim.x_min if min_density is None else min_density
    colors[rho < faint, 3] = FAINT_ALPHA
    widths = WIDTHS[0] + (WIDTHS[1] - WIDTHS[0]) * np.clip(mappable.norm(rho), 0.0, 1.0)
    fig = _new_figure(figsize=(8.0, 6.5), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Line3DCollection(segments, colors=colors, linewidths=widths))
    bodies = points[np.asarray(layout.bodies, dtype=int)]
    if len(bodies):
        ax.scatter(*bodies.T, color="black", s=12, depthshade=False)
    low, high = points.min(axis=0), points.max(axis=0)
    centre, half = (low + high) / 2, max(float(np.max(high - low)) / 2, 1e-12)
    ax.set(xlim=(centre[0] - half, centre[0] + half), ylim=(centre[1] - half, centre[1] + half),
           zlim=(centre[2] - half, centre[2] + half), xlabel="x (m)", ylabel="y (m)", zlabel="z (m)")
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=view[0], azim=view[1])
    if title is not None:
        ax.set_title(title)
    fig.colorbar(mappable, ax=ax, label="Density", shrink=0.7)
    return _save(fig, path)


def plot_spatial_paths(results: Any, rigid: Any, name: str, *, view: tuple[float, float] = (25.0, -60.0),
                       title: str | None = None, path: str | os.PathLike | None = None) -> Figure:
    """The path of ``name`` (a body or node) in spatial ``results`` against its ``rigid``
    trajectory (``SpatialSimulation.rigid_trajectory`` on the same grid), in 3D from ``view``,
    and their distance ``|r − r_rigid|`` (mm) over time, whose mean square is Eq. 40's."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection  # noqa: F401 (registers the 3d projection)

    moved, rigid = results.position(name), np.asarray(rigid, dtype=float)
    if rigid.shape != moved.shape or not np.all(np.isfinite(rigid)):
        raise SettingsError(f"rigid: expected {moved.shape} finite positions (one per state of the results), "
                            f"got shape {rigid.shape}")
    fig = _new_figure(figsize=(11.0, 5.0), layout="constrained")
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax.plot(*rigid.T, color="0.5", linestyle="--", label="rigid")
    ax.plot(*moved.T, color="C0", label=name)
    ax.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)")
    ax.view_init(elev=view[0], azim=view[1])
    ax.legend()
    gap = fig.add_subplot(1, 2, 2)
    gap.plot(results.time, 1e3 * np.linalg.norm(moved - rigid, axis=1), color="C0")
    gap.set(xlabel="time (s)", ylabel=f"|r − r_rigid| of {name} (mm)")
    if title is not None:
        fig.suptitle(title)
    return _save(fig, path)


def _positions(sim: Simulation, positions: Any) -> np.ndarray:
    """``positions`` as ``(n_nodes, 2)`` finite floats (``None``: the reference
    configuration), or a SettingsError naming them and the shape expected."""
    if positions is None:
        return np.asarray(sim.model.reference_positions)
    expected = f"finite numbers of shape ({len(sim.node_names)}, 2), one (x, y) per node"
    try:
        array = np.asarray(positions, dtype=float)
    except (TypeError, ValueError):
        raise SettingsError(f"positions must be {expected}, got {type(positions).__name__}") from None
    if array.shape != (len(sim.node_names), 2) or not np.isfinite(array).all():
        raise SettingsError(f"positions must be {expected}, got an array of shape {array.shape}"
                            + ("" if np.isfinite(array).all() else " with entries that are not finite"))
    return array


def _draw_bars(ax: Any, sim: Simulation, x: Any, segments: np.ndarray, shown: np.ndarray, faint: float | None,
               cmap: str | Colormap) -> ScalarMappable:
    lw, colors, mappable = _bar_style(sim, x, cmap, faint)
    order = np.flatnonzero(shown)[np.argsort(sim.bar_densities(x)[shown], kind="stable")]  # the solid bars on top
    ax.add_collection(LineCollection(segments[order], linewidths=lw[order], colors=colors[order], capstyle="round"))
    ax.margins(0.05)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return mappable


def _draw_cells(ax: Any, sim: Simulation, x: Any, positions: np.ndarray, shown: np.ndarray, cmap: str | Colormap) -> None:
    """The continuum members' cells ``shown`` (a mask over the cells) as quadrilaterals at
    ``positions``, filled by density on the bars' colour scale."""
    if not shown.any():
        return
    corners = np.asarray(sim.model.cells()["nodes"], dtype=int)[shown]
    _, _, mappable = _bar_style(sim, x, cmap, None)
    colors = mappable.to_rgba(sim.cell_densities(x)[shown])
    ax.add_collection(PolyCollection(positions[corners], facecolors=colors, edgecolors="none", zorder=1))
    ax.autoscale_view()


def _component_nodes(sim: Simulation, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Component ``k``'s bars, cells (masks) and the nodes they touch (a mask)."""
    cells = sim.model.cells()
    owner = [sim.components.index(name) for name in cells["members"]]
    bars = np.asarray(sim.bars.component) == k
    mine = np.array([owner[m] == k for m in cells["member"]], bool)
    own = np.zeros(len(sim.node_names), bool)
    own[np.asarray(sim.bars.nodes, dtype=int)[bars].ravel()] = True
    own[np.asarray(cells["nodes"], dtype=int)[mine].ravel()] = True
    return bars, mine, own


def _draw_supports(ax: Any, sim: Simulation, positions: np.ndarray, shown: np.ndarray) -> None:
    """What holds and moves the structure, at ``positions`` (``(n_nodes, 2)``) of the nodes
    ``shown``: a joint to the ground a triangle, a joint between parts a circle, a driven
    one filled red; a point mass a black square; a load an arrow along its force. A legend
    names them."""
    scale = 0.06 * float(np.max(np.ptp(positions[shown], axis=0))) if shown.any() else 1.0
    styles = {"ground joint": dict(marker="^", ms=8, mfc="white", mec="k"),
              "joint": dict(marker="o", ms=6, mfc="white", mec="k"),
              "driven joint": dict(marker="o", ms=7, mfc="C3", mec="k"),
              "point mass": dict(marker="s", ms=6, mfc="k", mec="k")}
    marks: dict[str, list[int]] = {name: [] for name in styles}
    for joint in sim.joints:
        kind = "driven joint" if joint.driven else "ground joint" if len(joint.nodes) == 1 else "joint"
        marks[kind] += [n for n in joint.nodes if shown[n]]
    marks["point mass"] = [n for n in (sim.node(p["node"]) for p in sim.spec.get("point_masses", [])) if shown[n]]
    for name, nodes in marks.items():
        if nodes:
            ax.plot(*positions[nodes].T, ls="none", zorder=3, label=name, **styles[name])
    loads = [(sim.node(load["node"]), np.asarray(load["force"], float)) for load in sim.spec.get("loads", [])]
    loads = [(node, force) for node, force in loads if shown[node] and np.any(force)]
    for node, force in loads:
        tail = positions[node] - scale * force / np.linalg.norm(force)
        ax.annotate("", xy=positions[node], xytext=tail, arrowprops=dict(arrowstyle="-|>", color="C1", lw=1.5), zorder=4)
    if loads:
        ax.plot([], [], color="C1", lw=1.5, label="load")
    if any(marks.values()) or loads:
        ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize="x-small", frameon=False, borderaxespad=0.2)


def _design_by_component(sim: Simulation, x: Any, title: str | None, faint: float | None, cmap: str | Colormap) -> Figure:
    """One panel per component, each in its own frame, stacked, with one colorbar."""
    nodes = np.asarray(sim.bars.nodes, dtype=int)
    reference = np.asarray(sim.model.reference_positions)
    frames = []
    for k in range(len(sim.components)):
        mine, cells, own = _component_nodes(sim, k)
        points = reference[own]
        centre = points.mean(axis=0)
        axis = np.linalg.svd(points - centre)[2][0]
        first = reference[np.flatnonzero(own).min()]  # the component's first node on the left
        axis = axis if (first - centre) @ axis <= 0 else -axis
        rotation = np.array([[axis[0], axis[1]], [-axis[1], axis[0]]])  # the long axis onto x
        local = (reference - centre) @ rotation.T
        frames.append((mine, cells, own, local - local[own].min(axis=0)))
    extent = np.array([np.ptp(local[own], axis=0) for _, _, own, local in frames]) + 1e-12
    width = float(extent[:, 0].max())
    heights = extent[:, 1] + 0.1 * width
    fig = _new_figure(figsize=(8.0, min(0.5 + float(np.sum(6.0 * heights / width + 0.75)), 12.0)), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(frames), 1, height_ratios=heights))
    for ax, (mine, cells, own, local), name in zip(axes, frames, sim.components):
        mappable = _draw_bars(ax, sim, x, local[nodes], mine, faint, cmap)
        _draw_cells(ax, sim, x, local, cells, cmap)
        _draw_supports(ax, sim, local, own)
        ax.set_title(name, fontsize="medium")
        ax.set_xlim(-0.03 * width, 1.03 * width)
    if title is not None:
        fig.suptitle(title)
    fig.colorbar(mappable, ax=list(axes), label="Density", location="right", shrink=0.8)
    return fig


def _field(record: Any, name: str) -> Any:
    return record[name] if isinstance(record, Mapping) else getattr(record, name)


def plot_history(history: Sequence[Any], *, path: str | os.PathLike | None = None, objective_label: str = "objective",
                 objective_scale: float | None = None, constraint_labels: Sequence[str] | None = None) -> Figure:
    """Convergence history of an optimization, from iteration 0 (the start design).

    ``history`` holds one record per iteration (objects or dicts with ``iteration``,
    ``f0``, ``g`` and ``change``), as :attr:`OptimizeResult.history`. Top panel: the
    objective as the optimizer saw it, ``f / f_ref``, on a log axis when it stays positive
    (one bad iteration then does not flatten the rest), with the response in its own
    units on the right axis when ``objective_scale`` (``f_ref``) is given. Bottom panel:
    every constraint by name (feasible when ≤ 0, the dotted zero line) and, on a log twin
    axis, the maximum design change.
    """
    if len(history) == 0:
        raise SettingsError("plot_history: the history is empty (an optimization's records, iteration 0 first)")
    it = np.array([_field(r, "iteration") for r in history], dtype=float)
    f0 = np.array([_field(r, "f0") for r in history], dtype=float)
    g = np.array([np.atleast_1d(np.asarray(_field(r, "g"), dtype=float)) for r in history])
    change = np.array([_field(r, "change") for r in history], dtype=float)
    change[it == 0] = np.nan  # the start design has not moved
    labels = list(constraint_labels) if constraint_labels is not None else [f"g{j + 1}" for j in range(g.shape[1])]
    if len(labels) != g.shape[1]:
        raise SettingsError(f"plot_history: {len(labels)} constraint labels for {g.shape[1]} constraints")

    fig = _new_figure(figsize=(7.0, 6.0), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.plot(it, f0, "o-", color="C0")
    top.set_ylabel(f"{objective_label} / f_ref" if objective_scale is not None else objective_label)
    if np.all(f0 > 0):
        top.set_yscale("log")
    if objective_scale is not None:
        right = top.secondary_yaxis("right", functions=(lambda v: v * objective_scale, lambda v: v / objective_scale))
        right.set_ylabel(responses.label(objective_label))
    top.grid(True, which="both", alpha=0.3)

    for j, label in enumerate(labels):
        bottom.plot(it, g[:, j], "o-", color=f"C{(j + 1) % 10}", label=label, ms=3)
    bottom.axhline(0.0, color="k", lw=0.8, ls=":")
    bottom.set_ylabel("constraints g (feasible ≤ 0)")
    bottom.set_xlabel("iteration")
    bottom.grid(True, alpha=0.3)
    twin = bottom.twinx()
    twin.plot(it, change, "s--", color="0.4", ms=3, label="design change")
    moved = change[np.isfinite(change) & (change > 0)]
    if moved.size and moved.max() > 10 * moved.min():  # a log axis only where the changes span a decade
        twin.set_yscale("log", nonpositive="mask")
    twin.set_ylabel("max design change")
    handles = bottom.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
    bottom.legend(handles=handles, loc="best", fontsize="small", ncols=2 if len(handles) > 6 else 1)
    return _save(fig, path)


def plot_tip_error(before: Results, after: Results | None = None, *, node: int | str | None = None,
                   path: str | os.PathLike | None = None,
                   labels: Sequence[str] = ("before optimization", "after optimization")) -> Figure:
    """Tip error against time (paper Fig. 9).

    For ``before`` (and ``after``, in a second panel side by side): the x and y components
    (mm) of ``node``'s position (the scene's tip by default) less its rigid trajectory;
    each title gives the run's ``labels`` entry, its mean squared tip deflection ``d`` and
    the peak error. Each panel has its own y axis, so that the smaller error's shape stays
    visible; the peaks in the titles compare them.
    """
    runs = [before] if after is None else [before, after]
    fig = _new_figure(figsize=(5.0 * len(runs), 4.0), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(runs)))
    for ax, res, label in zip(axes, runs, labels):
        error = 1e3 * res.tip_error(node)
        ax.plot(res.time, error[:, 0], label="x")
        ax.plot(res.time, error[:, 1], label="y")
        peak = float(np.max(np.linalg.norm(error, axis=1)))
        ax.set_title(f"{label}\nd = {res.tip_deflection(node):.3g} m², peak {peak:.3g} mm")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("tip − rigid trajectory (mm)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
    return _save(fig, path)


def plot_deformed(results: Any, *, magnify: float | None = None, title: str = "",
                  path: str | os.PathLike | None = None) -> Figure:
    """A static result: the structure at the reference (grey) and deformed (coloured by
    density), displacements × ``magnify`` (default: the largest drawn as a tenth of the
    structure's size), with its supports and loads; the title gives the largest
    displacement."""
    sim = results.simulation
    reference = np.asarray(sim.model.reference_positions)
    displacement = np.asarray(results.q).reshape(-1, 3)[:, :2]
    largest = float(np.max(np.linalg.norm(displacement, axis=1)))
    size = float(np.max(np.ptp(reference, axis=0)))
    magnify = (0.1 * size / largest if largest > 0 else 1.0) if magnify is None else magnify
    drawn = reference + magnify * displacement
    figsize, location = _design_layout(np.vstack([reference, drawn]))
    fig = _new_figure(figsize=figsize, layout="constrained")
    ax = fig.add_subplot()
    ax.add_collection(LineCollection(_segments(sim, reference), linewidths=0.6, colors="0.75"))
    mappable = _draw_bars(ax, sim, results.x, _segments(sim, drawn), np.ones(len(sim.bars), bool), None, DEFAULT_CMAP)
    _draw_supports(ax, sim, drawn, np.ones(len(drawn), bool))
    ax.set_title(f"{title}\ndeformed × {magnify:.3g} (grey: unloaded); largest displacement {1e3 * largest:.3g} mm".strip())
    fig.colorbar(mappable, ax=ax, label="Density", location=location, shrink=0.8)
    return _save(fig, path)


def plot_paths(results: Results, *, title: str = "", path: str | os.PathLike | None = None) -> Figure:
    """A motion in the plane: the path of every joint's, point mass's, rigid body's and ring's node
    (a scene without a tip, such as a pendulum), the structure at the start (grey) and at
    the end (black), equal axes."""
    sim = results.simulation
    positions = np.asarray(results.positions)
    traced = sorted({n for j in sim.joints for n in j.nodes} | {sim.node(p["node"]) for p in sim.spec.get("point_masses", [])}
                    | {sim.node(b["name"]) for b in sim.spec.get("rigid_bodies", []) + sim.spec.get("rings", [])})
    fig = _new_figure(figsize=(6.0, 5.0), layout="constrained")
    ax = fig.add_subplot()
    for k, colour in ((0, "0.7"), (-1, "k")):
        ax.add_collection(LineCollection(_segments(sim, positions[k]), linewidths=1.2, colors=colour))
    for i, n in enumerate(traced):
        ax.plot(positions[:, n, 0], positions[:, n, 1], color=f"C{i % 10}", lw=1.0, label=sim.node_names[n])
        ax.plot(*positions[0, n], "o", color=f"C{i % 10}", ms=4)
        ax.plot(*positions[-1, n], "s", color=f"C{i % 10}", ms=4)
    ax.set_aspect("equal")
    ax.autoscale()
    ax.margins(0.05)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{title}\npaths from t = 0 (circles) to {results.time[-1]:.3g} s (squares)".strip())
    if traced:
        ax.legend(fontsize="x-small", loc="best")
    return _save(fig, path)


def magnified_positions(results: Results, magnify: float) -> np.ndarray:
    """Drawn node positions ``rigid + magnify × (actual − rigid)``, shape
    ``(n_times, n_nodes, 2)``, where ``rigid`` are the positions of the rigid mechanism
    following the same drives at the same times."""
    rigid = results.simulation.rigid_positions(results.time)
    return rigid + magnify * (results.positions - rigid)


def animate(results: Results, path: str | os.PathLike, *, magnify: float = 10.0, fps: float = 20, x: Any = None,
            every: int | None = None) -> str | os.PathLike:
    """Writes an animated GIF of the moving mechanism and returns ``path``.

    One frame per ``every``-th time step (default: about :data:`flextop.io.export.FRAMES` frames), and the
    last: the bars between the
    :func:`magnified_positions` of their end nodes (elastic deflection × ``magnify``),
    coloured and sized by density ``x`` if given (with a colorbar; voids faint), the scene's tip and a
    faint trace of its rigid path, and the time. 5 × 5 in at 80 dpi.
    """
    if not isinstance(results, Results):
        raise TypeError("animate needs the Results of a dynamic run")
    sim = results.simulation
    drawn = magnified_positions(results, magnify)
    frames = frame_indices(len(results.time), every)

    fig = _new_figure(figsize=(5.0, 5.0), dpi=80, layout="constrained")
    ax = fig.add_subplot()
    if x is None:
        lines = LineCollection(_segments(sim, drawn[0]), linewidths=1.5, colors="0.2", capstyle="round")
    else:
        lw, colors, mappable = _bar_style(sim, x, DEFAULT_CMAP, 1.5 * sim.x_min, widths=(0.4, 4.0))  # voids faint
        lines = LineCollection(_segments(sim, drawn[0]), linewidths=lw, colors=colors, capstyle="round")
        fig.colorbar(mappable, ax=ax, label="Density", shrink=0.7)
    ax.add_collection(lines)
    points = [drawn[frames].reshape(-1, 2)]
    tip = None
    if sim.tip is not None:
        rigid_tip = sim.rigid_trajectory(sim.tip, results.time)
        ax.plot(rigid_tip[:, 0], rigid_tip[:, 1], color="0.6", lw=1.0, alpha=0.5)
        (tip,) = ax.plot(*drawn[0, sim.tip], "o", color="C3", ms=4)
        points.append(rigid_tip)
    lo, hi = np.min(np.vstack(points), axis=0), np.max(np.vstack(points), axis=0)
    pad = 0.05 * np.max(hi - lo)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"elastic deflection magnified × {magnify:g}")
    label = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top")

    fig.canvas.draw()
    fig.set_layout_engine("none")  # the layout does not change between frames
    writer = PillowWriter(fps=fps)
    with writer.saving(fig, path, dpi=80):
        for k in frames:
            lines.set_segments(_segments(sim, drawn[k]))
            if tip is not None:
                tip.set_data([drawn[k, sim.tip, 0]], [drawn[k, sim.tip, 1]])
            label.set_text(f"t = {results.time[k]:.3f} s")
            writer.grab_frame()
    return path

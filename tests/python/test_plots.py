"""Figures: density maps encode density in line width and colour, histories and tip errors
plot exactly the data given, animations have the right frames and magnification."""

from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from PIL import Image

import flextop
from flextop import plots


@pytest.fixture(scope="module")
def short_runs(arm):
    """Full-density and x = 0.4 runs of the robot arm over 0.5 s (11 steps)."""
    return arm.run(1.0, h=0.05, t_end=0.5), arm.run(0.4, h=0.05, t_end=0.5)


def two_bar_sim() -> flextop.Simulation:
    """A fixed bar split in 3 elements (interior nodes 3, 4) and one design bar."""
    scene = flextop.Scene("two_bars", analysis="static")
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02)
    scene.node("a", 0.0, 0.0)
    scene.node("b", 1.0, 0.0)
    scene.node("c", 1.0, 1.0)
    scene.beam("a", "b", section="al", split=3, fixed=True, name="fixed")
    scene.beam("b", "c", section="al", name="free")
    scene.clamp("base", "a")
    return flextop.Simulation(scene)


# -- plot_design --------------------------------------------------------------------------


def test_design_width_and_colour_follow_density(arm):
    x = np.random.default_rng(1).permutation(np.linspace(arm.x_min, 1.0, arm.n_design))
    fig = plots.plot_design(arm, x, by_component=False, min_density=0)
    lines = fig.axes[0].collections[0]
    rho = x[np.asarray(arm.bars.variable)]
    widths = np.asarray(lines.get_linewidths())
    assert widths.shape == rho.shape
    # Bars are drawn from the lightest to the densest, so that the solid ones lie on top.
    order = np.argsort(rho, kind="stable")
    segments = np.asarray(lines.get_segments())
    ends = np.asarray(arm.model.reference_positions)[np.asarray(arm.bars.nodes)]
    np.testing.assert_array_equal(segments, ends[order])
    assert np.all(np.diff(widths) > 0), "a denser bar must be drawn wider"
    assert widths[-1] / widths[0] > 5

    cmap, norm = matplotlib.colormaps[plots.DEFAULT_CMAP], Normalize(arm.x_min, 1.0)
    colors = lines.get_colors()
    np.testing.assert_allclose(colors[0], cmap(0.0))   # x_min: the colormap's low end
    np.testing.assert_allclose(colors[-1], cmap(1.0))  # full density: its high end
    np.testing.assert_allclose(colors, cmap(norm(rho[order])))
    colorbar = fig.axes[1]
    assert colorbar.get_ylabel() == "Density"
    np.testing.assert_allclose(colorbar.get_ylim(), (arm.x_min, 1.0))
    assert fig.axes[0].get_aspect() == 1.0


def test_a_member_s_void_cells_are_white_and_its_solid_ones_black():
    """The continuum cantilever, its top half void and its bottom half solid: each cell
    filled white at x_min, black at full density, grey in between by its density."""
    sim = flextop.Simulation(flextop.scenes.continuum_cantilever(nx=8, ny=4))
    centre = sim.model.cells()["centre"]
    x = np.where(centre[:, 1] > 0, sim.x_min, 1.0)
    x[0] = 0.5
    fig = plots.plot_design(sim, x)
    cells = next(c for c in fig.axes[0].collections if isinstance(c, matplotlib.collections.PolyCollection))
    colors = cells.get_facecolors()
    assert np.all(colors[(x == sim.x_min), :3] == 1.0) and np.all(colors[(x == 1.0), :3] == 0.0)
    grey = 1.0 - (0.5 - sim.x_min) / (1.0 - sim.x_min)
    np.testing.assert_allclose(colors[0, :3], grey, atol=1 / 255)


def test_design_draws_bars_between_end_nodes_fixed_at_full_density():
    sim = two_bar_sim()
    fig = plots.plot_design(sim, [sim.x_min], min_density=0.5)
    lines = fig.axes[0].collections[0]
    ref = sim.model.reference_positions
    # one straight segment per bar (the split bar's interior nodes are skipped)
    # (the light bar first, the solid one on top)
    np.testing.assert_allclose(lines.get_segments(), [ref[[1, 2]], ref[[0, 1]]])
    widths, colors = np.asarray(lines.get_linewidths()), lines.get_colors()
    cmap = matplotlib.colormaps[plots.DEFAULT_CMAP]
    assert widths[1] == pytest.approx(plots.WIDTHS[1]) and widths[0] == pytest.approx(plots.WIDTHS[0])
    np.testing.assert_allclose(colors[1], cmap(1.0))  # fixed bar: density 1, opaque
    assert colors[0][3] == pytest.approx(plots.FAINT_ALPHA)  # below min_density: faint
    # its support is drawn and named
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()] == ["ground joint"]
    with pytest.raises(flextop.errors.DesignError, match="the design has 2 entries; the scene has 1 design variables"):
        plots.plot_design(sim, [0.5, 0.5])


@pytest.mark.parametrize("value", [float("nan"), 3.0, -2.0])
@pytest.mark.parametrize("by_component", [False, True])
def test_a_design_outside_its_bounds_is_refused_as_a_run_refuses_it(arm, value, by_component):
    """plot_design drew densities NaN, 3.0 and −2.0: it raises the DesignError
    ``sim.run(x)`` raises, naming the variable."""
    x = np.full(arm.n_design, 0.5)
    x[7] = value
    with pytest.raises(flextop.DesignError) as run:
        arm.run(x)
    with pytest.raises(flextop.DesignError) as drawn:
        plots.plot_design(arm, x, by_component=by_component)
    assert str(drawn.value) == str(run.value) and str(run.value).startswith(f"x[7] ({arm.variable_names[7]}) = ")


@pytest.mark.parametrize(("positions", "got"), [
    ("three nodes", r"got an array of shape \(3, 2\)"),
    ("reference", r"got an array of shape \(\d+, 3\)"),
    ("nan", r"got an array of shape \(\d+, 2\) with entries that are not finite"),
    ("positions", r"got str"),
])
def test_positions_of_the_wrong_shape_are_named_with_the_shape_expected(arm, positions, got):
    """positions=<wrong shape> raised numpy's IndexError."""
    reference = np.asarray(arm.model.reference_positions)
    given = {"three nodes": np.zeros((3, 2)), "reference": np.column_stack([reference, reference[:, :1]]),
             "nan": np.where(np.arange(len(reference))[:, None] == 2, np.nan, reference)}.get(positions, positions)
    with pytest.raises(flextop.SettingsError, match=rf"positions must be finite numbers of shape \({len(reference)}, 2\), "
                                                    r"one \(x, y\) per node, " + got):
        plots.plot_design(arm, 0.5, positions=given)


def test_design_png_written_at_150_dpi(arm, tmp_path):
    path = tmp_path / "design.png"
    fig = plots.plot_design(arm, 0.5, path=path, title="x = 0.5")
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.size == tuple(np.round(fig.get_size_inches() * 150).astype(int))
        image.verify()

    own = Figure(figsize=(4, 3))
    ax = own.add_subplot()
    assert plots.plot_design(arm, 0.5, ax=ax, path=tmp_path / "own.png") is own
    assert ax.get_title() == ""
    with Image.open(tmp_path / "own.png") as image:
        assert image.size == (600, 450)


def test_design_by_component_draws_each_link_in_its_own_frame_with_faint_voids(arm):
    x = np.where(np.arange(arm.n_design) % 3 == 0, 1.0, arm.x_min)
    fig = plots.plot_design(arm, x)
    panels = [ax for ax in fig.axes if ax.get_title() in arm.components]
    assert [ax.get_title() for ax in panels] == ["link1", "link2"]
    component = np.asarray(arm.bars.component)
    for k, ax in enumerate(panels):
        lines = ax.collections[0]
        segments = np.asarray(lines.get_segments())
        assert len(segments) == (component == k).sum()
        # its own frame: 1 m along x from 0, 0.1 m across from 0, whatever the link's pose
        assert np.allclose([segments[..., 0].min(), segments[..., 0].max()], [0.0, 1.0], atol=1e-12)
        assert np.allclose([segments[..., 1].min(), segments[..., 1].max()], [0.0, 0.1], atol=1e-12)
        rho = np.sort(x[np.asarray(arm.bars.variable)[component == k]], kind="stable")
        alpha = lines.get_colors()[:, 3]
        assert np.all(alpha[rho <= arm.x_min] == plots.FAINT_ALPHA) and np.all(alpha[rho == 1.0] == 1.0)


# -- plot_history -------------------------------------------------------------------------


def history_dicts(n: int = 7) -> list[dict]:
    return [{"iteration": k + 1, "f0": 2.0 / (k + 1), "g": [0.3 - 0.1 * k, -0.2], "change": 0.5 ** k}
            for k in range(n)]


@pytest.mark.parametrize("kind", ["records", "dicts"])
def test_history_plots_one_point_per_iteration(kind):
    history = history_dicts()
    if kind == "records":
        history = [SimpleNamespace(**h, kkt=0.0) for h in history]
    fig = plots.plot_history(history, objective_label="tip deflection", constraint_labels=["V1", "V2"])
    top, bottom, twin = fig.axes
    (objective,) = top.get_lines()
    np.testing.assert_array_equal(objective.get_xdata(), np.arange(1, 8))
    np.testing.assert_allclose(objective.get_ydata(), [2.0 / (k + 1) for k in range(7)])
    assert top.get_ylabel() == "tip deflection"
    constraints = {line.get_label(): line for line in bottom.get_lines() if line.get_label() in ("V1", "V2")}
    assert len(constraints["V1"].get_xdata()) == len(history) == len(constraints["V2"].get_xdata())
    np.testing.assert_allclose(constraints["V1"].get_ydata(), [0.3 - 0.1 * k for k in range(7)])
    np.testing.assert_allclose(constraints["V2"].get_ydata(), -0.2)
    (change,) = twin.get_lines()
    np.testing.assert_allclose(change.get_ydata(), [0.5 ** k for k in range(7)])
    assert twin.get_yscale() == "log"


def test_history_rejects_bad_input():
    with pytest.raises(flextop.SettingsError, match="plot_history: the history is empty"):
        plots.plot_history([])
    with pytest.raises(flextop.SettingsError, match="1 constraint labels for 2 constraints"):
        plots.plot_history(history_dicts(), constraint_labels=["only one"])


# -- plot_tip_error -----------------------------------------------------------------------


def test_tip_error_plots_both_components(short_runs, tmp_path):
    before, after = short_runs
    fig = plots.plot_tip_error(before, after, path=tmp_path / "tip.png")
    assert (tmp_path / "tip.png").stat().st_size > 0
    assert len(fig.axes) == 2
    # Each panel its own y axis, so that the smaller error keeps its shape; peaks in the titles.
    assert not fig.axes[0].get_shared_y_axes().joined(fig.axes[0], fig.axes[1])
    for ax, res in zip(fig.axes, short_runs):
        ex, ey = ax.get_lines()
        assert (ex.get_label(), ey.get_label()) == ("x", "y")
        peak = 1e3 * np.linalg.norm(res.tip_error(), axis=1).max()
        assert ax.get_title().endswith(f"peak {peak:.3g} mm")
        np.testing.assert_array_equal(ex.get_xdata(), res.time)
        np.testing.assert_array_equal(ex.get_ydata(), 1e3 * res.tip_error()[:, 0])  # in mm
        np.testing.assert_array_equal(ey.get_ydata(), 1e3 * res.tip_error()[:, 1])
    assert fig.axes[0].get_ylabel() == "tip − rigid trajectory (mm)"
    assert fig.axes[0].get_title().startswith("before optimization")
    assert np.abs(after.tip_error()).max() > np.abs(before.tip_error()).max()  # the two panels differ

    (single,) = plots.plot_tip_error(before, labels=("full density",)).axes
    assert single.get_title().startswith("full density")


# -- animate ------------------------------------------------------------------------------


def test_magnified_positions_scale_the_deflection(arm, short_runs):
    res = short_runs[1]
    rigid = arm.rigid_positions(res.time)
    drawn = plots.magnified_positions(res, 10.0)
    np.testing.assert_array_equal(drawn, rigid + 10.0 * (res.positions - rigid))
    np.testing.assert_allclose(plots.magnified_positions(res, 1.0), res.positions, atol=1e-12)
    np.testing.assert_allclose(plots.magnified_positions(res, 0.0), rigid, atol=0)
    # the tip, through the independent tip_error path
    tip_rigid = arm.rigid_trajectory(arm.tip, res.time)
    np.testing.assert_allclose(drawn[:, arm.tip], tip_rigid + 10.0 * res.tip_error(), atol=1e-12)
    assert np.abs(res.tip_error()).max() > 1e-4  # the arm really deflects


def test_animate_writes_one_frame_per_step(arm, short_runs, tmp_path):
    res = short_runs[1]
    n = len(res.time)
    assert n == 11
    path = tmp_path / "arm.gif"
    assert plots.animate(res, path, x=np.full(arm.n_design, 0.4), every=3) == path
    with Image.open(path) as gif:
        assert gif.format == "GIF"
        assert gif.n_frames == 5  # steps 0, 3, 6, 9 and the last one, 10
        assert gif.size == (400, 400)
    plots.animate(res, tmp_path / "all.gif", magnify=50.0)
    with Image.open(tmp_path / "all.gif") as gif:
        assert gif.n_frames == n


def test_animate_draws_about_a_hundred_frames_of_a_long_run(arm, tmp_path):
    res = arm.run(0.4, h=0.005)  # 260 steps
    plots.animate(res, tmp_path / "long.gif", fps=50)
    with Image.open(tmp_path / "long.gif") as gif:
        assert 87 <= gif.n_frames <= 101 and gif.info["duration"] == 20  # ms per frame at 50 fps


def test_history_from_iteration_zero_on_a_log_axis_in_both_units():
    history = [{"iteration": k, "f0": 10.0 ** -k, "g": [-0.1], "change": 0.0 if k == 0 else 0.1} for k in range(5)]
    fig = plots.plot_history(history, objective_label="tip_deflection", objective_scale=2e-3, constraint_labels=["volume:link1"])
    top = fig.axes[0]
    (objective,) = top.get_lines()
    assert objective.get_xdata()[0] == 0 and top.get_yscale() == "log" and top.get_ylabel() == "tip_deflection / f_ref"
    (right,) = top.child_axes
    assert right.get_ylabel() == "tip_deflection (m²)"  # the engine's unit: "(its units)" before
    assert [t.get_text() for t in fig.axes[1].get_legend().get_texts()] == ["volume:link1", "design change"]


def test_animate_needs_a_dynamic_run(tmp_path):
    static = flextop.Simulation(flextop.scenes.static_truss()).run(0.5)
    with pytest.raises(TypeError, match="dynamic"):
        plots.animate(static, tmp_path / "static.gif")


def test_plots_are_reached_from_the_package_as_the_readme_uses_them():
    """``import flextop`` then ``flextop.plots.plot_design``: matplotlib loads on first use."""
    import subprocess
    import sys
    code = ("import sys, flextop; assert 'matplotlib' not in sys.modules; "
            "assert callable(flextop.plots.plot_design) and 'matplotlib' in sys.modules; "
            "assert flextop.io.export.__name__ == 'flextop.io.export'")
    assert subprocess.run([sys.executable, "-c", code], timeout=120).returncode == 0

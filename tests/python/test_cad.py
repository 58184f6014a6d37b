"""A member's shape for CAD (flextop.io.cad): the outline against the thresholded densities
and against an exact region, its holes, its rings, and the files read back — DXF by ezdxf,
STL by numpy-stl and trimesh, SVG as XML."""

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import flextop
from flextop.io import cad

shapely = pytest.importorskip("shapely")
ezdxf = pytest.importorskip("ezdxf")
stl = pytest.importorskip("stl")
trimesh = pytest.importorskip("trimesh")

LENGTH, HEIGHT, THICKNESS, NX, NY = 0.2, 0.1, 0.01, 40, 20
CELL = (LENGTH / NX) * (HEIGHT / NY)  # a cell's area, m²


@pytest.fixture(scope="module")
def plate():
    """A 0.2 m × 0.1 m plate of 40 × 20 cells, 10 mm thick, pinned at its left corners."""
    scene = flextop.Scene("plate", analysis="static")
    member = scene.member("plate", nx=NX, ny=NY, length=LENGTH, height=HEIGHT, thickness=THICKNESS, E=2e11, nu=0.3, rho=7800.0)
    scene.pin("lower", member.node(0, 0))
    scene.pin("upper", member.node(0, NY))
    scene.load(member.node(NX, NY // 2), force=(0.0, -100.0))
    return flextop.Simulation(scene)


def design(sim, density):
    """The design whose cells take ``density(centres)`` (clipped to [x_min, 1])."""
    cells = sim.model.cells()
    variable = np.asarray(cells["variable"])
    x = np.ones(sim.n_design)
    x[variable[variable >= 0]] = np.clip(density(cells["centre"]), sim.x_min, 1.0)[variable >= 0]
    return x


def holed(r0, width=0.02):
    """Densities rising linearly from 0.5 at radius ``r0`` (m) about the plate's centre,
    by 1 over ``width`` (m): a round hole of radius ``r0`` at threshold 0.5."""
    return lambda c: 0.5 + (np.hypot(c[:, 0] - LENGTH / 2, c[:, 1]) - r0) / width


def cell_boxes(sim, shrink=0.0):
    """Each cell's square in the member's frame (the plate is not placed or turned),
    ``shrink`` (m) inside its edges."""
    c, half = sim.model.cells()["centre"], LENGTH / NX / 2 - shrink
    return shapely.box(c[:, 0] - half, c[:, 1] - half, c[:, 0] + half, c[:, 1] + half)


@pytest.mark.parametrize("r0", [0.02, 0.031])
def test_a_round_hole_is_one_interior_ring_of_the_exact_area(plate, r0):
    """The densities of a hole of radius r0: one polygon with one interior ring, centred on
    the hole, its area that of the plate less πr0² within two cells. Why two: the nodes'
    mean of the cells shifts a level set by h²κ/8 (the mean's h²/8 ∇²ρ over |∇ρ|), which on
    a closed ring adds 2π·h²/8 ≈ 0.8 of a cell's area; the interpolation adds less."""
    shape = cad.outline(plate, design(plate, holed(r0)))
    assert shape.geom_type == "Polygon" and shape.is_valid and len(shape.interiors) == 1
    hole = shapely.Polygon(shape.interiors[0])
    assert hole.centroid.distance(shapely.Point(LENGTH / 2, 0.0)) < 0.05 * math.sqrt(CELL)
    assert shape.area == pytest.approx(LENGTH * HEIGHT - math.pi * r0**2, abs=2 * CELL)
    assert shape.bounds == pytest.approx((0.0, -HEIGHT / 2, LENGTH, HEIGHT / 2), abs=1e-12)


@pytest.mark.parametrize("threshold", [0.3, 0.5, 0.7])
def test_the_outline_holds_exactly_the_cells_above_the_threshold_where_it_does_not_cross_them(plate, threshold):
    """Two holes of a smooth field, the ridge between them a kink the smoothing rounds:
    every cell that the outline does not cross lies inside it exactly when its density
    reaches the threshold, and the outline's area is the thresholded cells' to a thousandth
    of a cell (traced at threshold itself it was 1.9 cells short at 0.3, 4.9 and 12.5 over
    at 0.5 and 0.7)."""
    x = design(plate, lambda c: np.minimum(holed(0.025)(c + [0.05, 0.0]), holed(0.02)(c - [0.05, 0.0])))
    shape = cad.outline(plate, x, threshold=threshold)
    assert len(shape.interiors) == 2
    density = plate.cell_densities(x)
    crossed = shapely.intersects(cell_boxes(plate, shrink=1e-9), shape.boundary)
    inside = shapely.within(cell_boxes(plate), shape.buffer(1e-12))
    np.testing.assert_array_equal(inside[~crossed], density[~crossed] >= threshold)
    assert shape.area == pytest.approx(CELL * np.count_nonzero(density >= threshold), abs=cad.AREA_TOLERANCE * CELL)
    assert 10 < np.count_nonzero(crossed) < 0.2 * NX * NY


@pytest.mark.parametrize("seed", [0, 1])
def test_a_random_design_s_outline_holds_the_thresholded_area(plate, seed):
    """Densities drawn at random in every cell, the field the smoothing changes most: the
    outline is still valid and holds the area of the cells at 0.5 or more to a thousandth of
    a cell (traced at 0.5 itself, seed 0's was 31.5 cells over)."""
    x = np.random.default_rng(seed).uniform(plate.x_min, 1.0, plate.n_design)
    shape = cad.outline(plate, x)
    assert shape.is_valid
    target = CELL * np.count_nonzero(plate.cell_densities(x) >= 0.5)
    assert shape.area == pytest.approx(target, abs=cad.AREA_TOLERANCE * CELL)


def test_the_dxf_holds_closed_polylines_of_the_outline_in_millimetres(plate, tmp_path):
    x = design(plate, holed(0.03))
    shape = cad.outline(plate, x)
    paths = cad.write(plate, x, tmp_path)
    assert sorted(p.name for p in paths) == ["plate.dxf", "plate.stl", "plate.svg"]
    document = ezdxf.readfile(tmp_path / "plate.dxf")
    assert document.units == ezdxf.units.MM
    lines = list(document.modelspace().query("LWPOLYLINE"))
    assert len(lines) == 2 and all(line.closed for line in lines)
    rings = {line.dxf.layer: shapely.Polygon(np.asarray(line.get_points("xy"))) for line in lines}
    assert rings.keys() == {"OUTLINE", "HOLES"}
    area = rings["OUTLINE"].area - rings["HOLES"].area
    assert area == pytest.approx(shape.area * 1e6, rel=1e-12)
    assert rings["OUTLINE"].area == pytest.approx(LENGTH * HEIGHT * 1e6, rel=1e-12)


def test_the_stl_is_a_closed_solid_of_the_outline_times_the_thickness(plate, tmp_path):
    x = design(plate, holed(0.03))
    shape = cad.outline(plate, x)
    cad.write(plate, x, tmp_path)
    volume, centre, _ = stl.mesh.Mesh.from_file(tmp_path / "plate.stl").get_mass_properties()
    assert volume == pytest.approx(shape.area * THICKNESS * 1e9, rel=1e-7)  # STL's single precision
    assert centre == pytest.approx([LENGTH / 2 * 1e3, 0.0, THICKNESS / 2 * 1e3], abs=1e-6 * 1e3)
    solid = trimesh.load(tmp_path / "plate.stl")
    assert solid.is_watertight and solid.is_volume
    assert solid.euler_number == 0  # a solid with one hole through it: a torus's


def test_the_svg_is_drawn_at_full_scale(plate, tmp_path):
    """The page is the plate in millimetres and the 5 mm margins: 1:1."""
    cad.write(plate, design(plate, holed(0.03)), tmp_path)
    root = ET.parse(tmp_path / "plate.svg").getroot()
    assert root.get("width") == f"{LENGTH * 1e3 + 10:g}mm" and root.get("height") == f"{HEIGHT * 1e3 + 10:g}mm"
    assert len(root.findall(".//{http://www.w3.org/2000/svg}path")) == 2


def bracket():
    """A 0.2 m × 0.08 m bracket of 20 × 8 cells whose bore (the member's hole of 4 × 4
    cells) carries a ring pinned to the ground, its left edge pinned, every cell designed
    (``solid_at_joints=False``)."""
    scene = flextop.Scene("bracket", analysis="static")
    member = scene.member("bracket", nx=20, ny=8, length=0.2, height=0.08, thickness=0.005, E=2e11, nu=0.3, rho=7800.0,
                          holes=[(8, 2, 12, 6)], solid_at_joints=False)
    scene.ring("bore", [member.node(i, j) for i in range(8, 13) for j in range(2, 7) if i in (8, 12) or j in (2, 6)])
    scene.pin("bearing", "bore")
    for j in range(9):
        scene.pin(f"wall{j}", member.node(0, j))
    scene.load(member.node(20, 0), force=(0.0, -100.0))
    sim = flextop.Simulation(scene)
    assert sim.n_design == len(sim.model.cells()["variable"])
    return sim


def test_a_ring_s_cells_stay_in_the_shape_and_the_member_s_hole_stays_a_hole():
    """The bracket void but for its top and bottom rows of cells: the ring's cells, void in
    the design, are in the outline all the same, the bore is its one interior ring, and the
    outline's area is the rows' and the ring's cells'."""
    sim = bracket()
    centre = sim.model.cells()["centre"]
    shape = cad.outline(sim, np.where(np.abs(centre[:, 1]) > 0.03, 1.0, sim.x_min))
    ring = shapely.union_all([shapely.box(0.07 + 0.01 * a, -0.03 + 0.01 * b, 0.08 + 0.01 * a, -0.02 + 0.01 * b)
                              for a in range(6) for b in range(6) if a in (0, 5) or b in (0, 5)])
    assert ring.area == pytest.approx(20 * 1e-4)
    assert shape.buffer(1e-12).contains(ring)
    assert len(shape.interiors) == 1
    bore = shapely.Polygon(shape.interiors[0]).symmetric_difference(shapely.box(0.08, -0.02, 0.12, 0.02))
    assert bore.area < 1e-15
    rows = 2 * 0.2 * 0.01
    # Smoothing fills the rows' inner corners where the ring meets them; the level taken
    # gives that area back along the rows.
    assert shape.area == pytest.approx(rows + ring.area, abs=cad.AREA_TOLERANCE * 1e-4)


def test_bad_input_is_named(plate):
    x = design(plate, holed(0.03))
    for threshold in (0.0, 1.0, 1.5, float("nan")):
        with pytest.raises(flextop.SettingsError, match="threshold"):
            cad.outline(plate, x, threshold=threshold)
    with pytest.raises(flextop.SettingsError, match="unit must be one of mm, m"):
        cad.write(plate, x, "unused", unit="inch")
    with pytest.raises(flextop.DesignError, match="entries"):
        cad.outline(plate, x[:-1])
    bad = x.copy()
    bad[7] = np.nan
    with pytest.raises(flextop.DesignError, match=r"x\[7\]"):
        cad.outline(plate, bad)
    scene = flextop.Scene("sheet", analysis="static")
    sheet = scene.member("sheet", nx=4, ny=2, length=0.2, height=0.1, thickness=0.01, E=2e11, nu=0.3, rho=7800.0,
                         solid_at_joints=False)
    for j in range(3):
        scene.pin(f"wall{j}", sheet.node(0, j))
    scene.load(sheet.node(4, 1), force=(0.0, -100.0))
    void = flextop.Simulation(scene)
    with pytest.raises(flextop.DesignError, match="member 'sheet': no part of it reaches density 0.6 .its densest cell is 0.5"):
        cad.outline(void, np.full(void.n_design, 0.5), threshold=0.6)
    with pytest.raises(flextop.SceneError, match="has no continuum member"):
        cad.outline(flextop.Simulation(flextop.scenes.static_truss()), None)
    arm = flextop.Simulation(flextop.scenes.continuum_robot_arm(nx=8, ny=4))
    with pytest.raises(flextop.SceneError, match=r"2 continuum members \(link1, link2\): name the one"):
        cad.outline(arm, None)
    with pytest.raises(flextop.SceneError, match="no continuum member 'link3'"):
        cad.outline(arm, None, "link3")


def test_every_designed_member_of_a_scene_is_written_in_its_own_frame(tmp_path):
    """The continuum arm's two links, turned in the scene, come out along x: each a solid
    1 m × 0.1 m link at full density."""
    arm = flextop.Simulation(flextop.scenes.continuum_robot_arm(nx=8, ny=4))
    written = cad.write(arm, np.ones(arm.n_design), tmp_path, unit="m")
    assert sorted(p.name for p in written) == sorted(f"link{k}.{s}" for k in (1, 2) for s in ("dxf", "svg", "stl"))
    for link in ("link1", "link2"):
        shape = cad.outline(arm, np.ones(arm.n_design), link)
        assert shape.bounds == pytest.approx((0.0, -0.05, 1.0, 0.05), abs=1e-12)
        volume = stl.mesh.Mesh.from_file(tmp_path / f"{link}.stl").get_mass_properties()[0]
        assert volume == pytest.approx(1.0 * 0.1 * 0.005, rel=1e-7)  # STL's single precision

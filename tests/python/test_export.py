"""ParaView output and section forces: statics against the beam's equilibrium, a VTU series
read back by meshio (and VTK's own reader when installed) equal to the results."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

import flextop
from flextop.io import export

from conftest import cantilever

meshio = pytest.importorskip("meshio")


def test_section_forces_of_a_cantilever_balance_its_loads():
    """Cut the deformed cantilever at each element's first node: the part beyond carries the
    tip load F alone, so the element's axial force is F along its deformed chord and its
    first end moment is the moment of F about that node (exact equilibrium, large rotations
    included)."""
    load = np.array([300.0, -40.0])
    scene = cantilever(1.0, 4, analysis="static")
    scene.load("tip", force=tuple(load))
    sim = flextop.Simulation(scene)
    res = sim.run()
    n, m1, _ = res.section_forces[0].T
    nodes = np.asarray(sim.model.elements()["nodes"], dtype=int)
    r = res.positions
    chord = r[nodes[:, 1]] - r[nodes[:, 0]]
    along = chord / np.linalg.norm(chord, axis=1)[:, None]
    assert np.allclose(n, along @ load, rtol=1e-8)
    arm_ = r[sim.node("tip")] - r[nodes[:, 0]]
    moment = arm_[:, 0] * load[1] - arm_[:, 1] * load[0]
    assert np.allclose(np.abs(m1), np.abs(moment), rtol=1e-8)


def test_a_motion_series_reads_back_equal_to_the_results(tmp_path, arm):
    res = arm.run(0.4)
    index = res.to_vtk(tmp_path / "arm.pvd", every=7)
    sets = list(ET.parse(index).getroot().iter("DataSet"))
    steps = sorted(set(range(0, len(res.time), 7)) | {len(res.time) - 1})
    assert [float(d.get("timestep")) for d in sets] == [float(res.time[k]) for k in steps]
    elements = arm.model.elements()
    for data, k in zip(sets, steps):
        mesh = meshio.read(tmp_path / data.get("file"))
        # A motion's frames hold the current points and no displacement for Warp By Vector
        # to add a second time (it held the whole motion before).
        assert np.abs(mesh.points[:, :2] - res.positions[k]).max() <= 1e-12
        assert "displacement" not in mesh.point_data
        assert np.array_equal(mesh.cells_dict["line"], elements["nodes"])
        assert np.allclose(mesh.point_data["velocity"][:, :2], res.qdot[k].reshape(-1, 3)[:, :2], rtol=0, atol=1e-12)
        for name in ("density", "axial_force", "moment_1", "moment_2", "axial_stress", "bar"):
            assert name in mesh.cell_data
        assert np.allclose(mesh.cell_data["axial_force"][0], res.section_forces[k][:, 0], rtol=1e-14, atol=0)
        assert np.allclose(mesh.cell_data["density"][0], 0.4)
    kinds = mesh.cell_data["vertex"][1]
    assert (kinds == export.JOINT).sum() == 3 and (kinds == export.POINT_MASS).sum() == 1  # shoulder, elbow's two nodes; payload


def test_vtks_own_reader_agrees(tmp_path, arm):
    vtk = pytest.importorskip("vtk")
    res = arm.run(0.4)
    res.to_vtk(tmp_path / "arm.pvd", every=1000)
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(tmp_path / f"arm_{len(res.time) - 1:05d}.vtu"))
    reader.Update()
    grid = reader.GetOutput()
    points = np.array([grid.GetPoint(i)[:2] for i in range(grid.GetNumberOfPoints())])
    assert np.abs(points - res.positions[-1]).max() <= 1e-12
    assert grid.GetCellData().GetArray("axial_stress") is not None


def test_a_design_and_a_static_result_export_as_one_file(tmp_path, arm):
    x = np.linspace(arm.x_min, 1.0, arm.n_design)
    mesh = meshio.read(export.write_design(arm, x, tmp_path / "design.vtu"))
    bar = np.asarray(arm.model.elements()["bar"])
    assert np.allclose(mesh.cell_data["density"][0], x[np.asarray(arm.bars.variable)[bar]])
    truss = flextop.Simulation(flextop.scenes.static_truss())
    res = truss.run(0.5)
    mesh = meshio.read(res.to_vtk(tmp_path / "truss.vtu"))
    # A static result: reference points, and Warp By Vector's arithmetic (points + scale ×
    # displacement) at scale 1 gives the deformed structure.
    reference = np.asarray(truss.model.reference_positions)
    assert np.array_equal(mesh.points[:, :2], reference) and not np.all(mesh.point_data["displacement"] == 0.0)
    assert np.abs(mesh.points[:, :2] + 1.0 * mesh.point_data["displacement"][:, :2] - res.positions).max() <= 1e-12
    with pytest.raises(flextop.SettingsError, match=r"\.pvd"):
        arm.run(0.4).to_vtk(tmp_path / "arm.vtu")


@pytest.mark.parametrize("value", [float("nan"), 3.0, -2.0])
@pytest.mark.parametrize("scene", ["robot_arm", "continuum_robot_arm"])
def test_a_design_outside_its_bounds_is_refused_as_a_run_refuses_it(tmp_path, scene, value):
    """write_design wrote densities NaN, 3.0 and −2.0 into the VTU where ``sim.run(x)``
    raises: it raises the same DesignError, naming the variable, and writes nothing."""
    sim = flextop.Simulation(getattr(flextop.scenes, scene)())
    x = np.full(sim.n_design, 0.5)
    x[7] = value
    with pytest.raises(flextop.DesignError) as run:
        sim.run(x)
    assert str(run.value).startswith(f"x[7] ({sim.variable_names[7]}) = ")
    with pytest.raises(flextop.DesignError) as written:
        export.write_design(sim, x, tmp_path / "design.vtu")
    assert str(written.value) == str(run.value) and not (tmp_path / "design.vtu").exists()


def test_the_command_line_writes_paraview_files(tmp_path):
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-m", "flextop.cli", "simulate", "robot_arm", "--x", "0.4", "--out", str(tmp_path), "--vtk"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    files = [d.get("file") for d in ET.parse(tmp_path / "motion.pvd").getroot().iter("DataSet")]
    assert 60 <= len(files) <= 101 and all((tmp_path / f).exists() for f in files)
    missing = subprocess.run([sys.executable, "-m", "flextop.cli", "simulate", "robot_arm", "--vtk"], capture_output=True, text=True, timeout=300)
    assert missing.returncode == 2 and "give --out" in missing.stderr and "steps of" not in missing.stdout

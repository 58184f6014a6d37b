"""The command line, end to end in subprocesses."""

import json
import re
import shlex
import shutil
import subprocess
import sys

import numpy as np
import pytest

import flextop
import flextop.cli

from conftest import EXAMPLES, ROOT, lattice_cantilever


def flextop_cli(*args, check=True, codes=(0,)):
    """The command's run; with ``check``, its exit code must be one of ``codes`` (3: an
    optimization stopped without converging, e.g. at --max-iter)."""
    run = subprocess.run([sys.executable, "-m", "flextop.cli", *map(str, args)], capture_output=True, text=True, timeout=300)
    if check:
        assert run.returncode in codes, run.stderr
    return run


def test_console_script_is_installed():
    exe = shutil.which("flextop")
    assert exe is not None
    run = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0 and "optimize" in run.stdout


def test_version_is_the_installed_package_s():
    from importlib.metadata import version
    run = flextop_cli("--version")
    assert run.stdout.strip() == f"flextop {version('flextop')}" == f"flextop {flextop.__version__}"


def test_a_scene_without_design_variables_is_one_line_not_a_traceback(tmp_path):
    run = flextop_cli("optimize", "pendulum", "--out", tmp_path, check=False)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert run.stderr.strip() == "flextop: error: the scene has no design variables (no bars, or all of them fixed): nothing to optimize"


def test_optimize_exits_0_only_when_the_optimizer_converged(tmp_path):
    run = flextop_cli("optimize", "static_truss", "--max-iter", 20, "--out", tmp_path, "--no-plots")
    assert "status: KKT" in run.stdout and run.stderr.count("did not converge") == 0
    stalled = flextop_cli("optimize", "static_truss", "--xtol", "0.5", "--max-iter", 20, "--out", tmp_path / "s", "--no-plots",
                          codes=(3,))
    assert "stalled" in stalled.stderr and "KKT residual" in stalled.stderr
    limited = flextop_cli("optimize", "static_truss", "--max-iter", 1, "--out", tmp_path / "b", "--no-plots", codes=(3,))
    assert limited.stderr.strip().splitlines()[-1].startswith("flextop: the optimizer did not converge: maximum number")


def test_demo_prints_tip_error_and_d_and_writes_a_plot(tmp_path):
    run = flextop_cli("demo", "--out", tmp_path)
    d = float(re.search(r"mean squared tip deflection d = ([0-9.e+-]+)", run.stdout).group(1))
    assert d == pytest.approx(flextop.Simulation(flextop.scenes.robot_arm()).run(0.4).tip_deflection(), rel=1e-6)
    assert "max |r - r_rigid|" in run.stdout
    assert (tmp_path / "tip_error.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_simulate_a_scene_file_and_save_results(tmp_path):
    run = flextop_cli("simulate", EXAMPLES / "robot_arm.toml", "--x", "0.4", "--h", "0.01", "--out", tmp_path)
    assert "130 steps of h = 0.01 s" in run.stdout
    saved = flextop.load(tmp_path / "results.npz")
    assert saved.q.shape == (131, 90) and saved.raw["h"] == 0.01
    assert saved.tip_deflection() == pytest.approx(float(re.search(r"d = ([0-9.e+-]+)", run.stdout).group(1)), rel=1e-6)
    assert (tmp_path / "tip_error.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("scene, figure, title", [
    ("pendulum", "paths.png", "pendulum, no design variables"),
    ("static_truss", "deformed.png", "static_truss, x = 0.4 on every bar"),
    ("robot_arm", "tip_error.png", "robot_arm, x = 0.4 on every bar"),
])
def test_every_simulated_scene_gets_a_figure_titled_by_its_design(tmp_path, monkeypatch, scene, figure, title):
    """The pendulum and the static truss wrote no figure; the arm's was titled "before
    optimization" by a command that optimizes nothing. simulate runs x = 0.4 by default,
    as demo and optimize do."""
    from flextop import cli, plots

    titles = []
    for name in ("plot_paths", "plot_deformed", "plot_tip_error"):
        def spy(*args, _original=getattr(plots, name), **kwargs):
            titles.append(kwargs.get("title") or kwargs.get("labels", ("",))[0])
            return _original(*args, **kwargs)
        monkeypatch.setattr(plots, name, spy)
    assert cli.main(["simulate", scene, "--out", str(tmp_path)]) == 0
    assert (tmp_path / figure).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert titles == [title]


def test_a_fixed_run_prints_its_own_error_estimate_and_says_when_it_is_rough():
    """The full-density arm at the scene's step is tens of percent off; x = 0.4 is not."""
    rough = flextop_cli("simulate", EXAMPLES / "robot_arm.toml", "--x", "1.0")
    estimate = float(re.search(r"d = [0-9.e+-]+ m\^2 \(estimated error ([0-9.]+)%", rough.stdout).group(1)) / 100
    res = flextop.Simulation(flextop.scenes.robot_arm()).run(1.0)
    assert estimate == pytest.approx(res.error_estimate("tip_deflection"), abs=1e-3) and estimate > 0.3
    assert "too coarse" in rough.stdout and "--rtol" in rough.stdout
    fine = flextop_cli("simulate", EXAMPLES / "robot_arm.toml", "--x", "0.4")
    assert "(estimated error" in fine.stdout and "too coarse" not in fine.stdout


def test_simulate_to_a_tolerance_or_with_local_error_control():
    run = flextop_cli("simulate", EXAMPLES / "robot_arm.toml", "--x", "0.4", "--rtol", "1e-2")
    d = float(re.search(r"mean squared tip deflection d = ([0-9.e+-]+)", run.stdout).group(1))
    res = flextop.Simulation(flextop.scenes.robot_arm(), rtol=1e-2).run(0.4)
    assert d == pytest.approx(res.tip_deflection(), rel=1e-6)
    assert f"to rtol = 0.01: {res.discretization}; estimated relative error tip_deflection" in run.stdout
    run = flextop_cli("simulate", EXAMPLES / "robot_arm.toml", "--x", "0.4", "--local-tol", "1e-5")
    assert re.search(r"\d+ steps of h = [0-9.e-]+ … [0-9.e-]+ s to t = 1.3 s", run.stdout), run.stdout
    both = flextop_cli("simulate", EXAMPLES / "robot_arm.toml", "--rtol", "1e-2", "--h", "0.01", check=False)
    assert both.returncode == 2 and both.stderr.strip().count("\n") == 0 and "not both" in both.stderr


def test_bad_input_exits_with_a_named_error():
    run = flextop_cli("simulate", EXAMPLES / "robot_arm.toml", "--x", "2", check=False)
    assert run.returncode == 2 and "x[0] (link1/bar0) = 2 is outside [0.01, 1]" in run.stderr


def history(path):
    return json.loads((path / "history.json").read_text())["history"]


def test_optimize_checkpoints_and_resumes_exactly(tmp_path):
    straight, split = tmp_path / "straight", tmp_path / "split"
    flextop_cli("optimize", "static_truss", "--objective", "compliance", "--max-iter", 8, "--out", straight, "--no-plots", codes=(0, 3))
    flextop_cli("optimize", "static_truss", "--objective", "compliance", "--max-iter", 4, "--out", split, "--no-plots", codes=(0, 3))
    checkpoint = json.loads((split / "checkpoint.json").read_text())["data"]
    assert checkpoint["state"]["iteration"] == 4 and len(history(split)) == 5  # iterations 0 to 4
    run = flextop_cli("optimize", "--resume", "--max-iter", 8, "--out", split, "--no-plots", codes=(0, 3))
    assert "resuming" in run.stdout
    assert [h["iteration"] for h in history(split)] == list(range(0, 9))
    np.testing.assert_allclose(np.load(split / "design.npy"), np.load(straight / "design.npy"), rtol=0, atol=1e-12)
    assert [h["f0"] for h in history(split)] == pytest.approx([h["f0"] for h in history(straight)], rel=1e-12)


def test_a_spatial_optimization_checkpoints_and_resumes_exactly(tmp_path):
    """The lattice cantilever's energy at 30 % of its volume under a peak stress limit (its
    normalization moves at every iteration and travels in the checkpoint): 8 iterations in
    one run and 4 + 4 resumed give the same history and design to round-off."""
    (tmp_path / "lattice.toml").write_text(lattice_cantilever().to_toml())
    straight, split = tmp_path / "straight", tmp_path / "split"
    options = ("--volume-fraction", "0.3", "--x0", "0.3", "--max-stress", "5e7", "--no-plots")
    flextop_cli("optimize", tmp_path / "lattice.toml", *options, "--max-iter", 8, "--out", straight, codes=(0, 3))
    flextop_cli("optimize", tmp_path / "lattice.toml", *options, "--max-iter", 4, "--out", split, codes=(0, 3))
    saved = json.loads((split / "checkpoint.json").read_text())["data"]
    assert saved["spatial"] and saved["state"]["iteration"] == 4 and saved["problem"]["normalization"]
    run = flextop_cli("optimize", "--resume", "--max-iter", 8, "--out", split, "--no-plots", codes=(0, 3))
    assert "resuming" in run.stdout and "minimize strain_energy over 72 densities" in run.stdout
    assert [h["iteration"] for h in history(split)] == list(range(0, 9))
    np.testing.assert_allclose(np.load(split / "design.npy"), np.load(straight / "design.npy"), rtol=0, atol=1e-12)
    assert [h["f0"] for h in history(split)] == pytest.approx([h["f0"] for h in history(straight)], rel=1e-12)
    done = flextop_cli("optimize", "--resume", "--max-iter", 8, "--out", split, codes=(1, 2))
    assert done.stderr.count("\n") == 1 and "has done its 8 iterations" in done.stderr


def plate_toml(tmp_path):
    """A cantilever plate of 12 × 4 cells pinned along its left edge, loaded down at its
    lower right corner: its TOML file in ``tmp_path``."""
    scene = flextop.Scene("plate", analysis="static")
    plate = scene.member("plate", nx=12, ny=4, length=0.6, height=0.2, thickness=0.01, E=70e9, nu=0.3, rho=2700.0)
    for j in range(5):
        scene.pin(f"wall{j}", plate.node(0, j))
    scene.load(plate.node(12, 0), force=(0.0, -1e3))
    (tmp_path / "plate.toml").write_text(scene.to_toml())
    return tmp_path / "plate.toml"


def test_a_continuum_member_optimizes_with_a_filter_and_resumes_exactly(tmp_path):
    """A cantilever plate of 12 × 4 cells, compliance under one volume constraint, the
    density filter (60 mm) with a projection: the checkpoint holds the filter, and a run
    stopped after 3 iterations and resumed to 6 is the uninterrupted one. densities.npy holds
    the filtered, projected densities of design.npy, cad/ the outline of those densities
    at 0.5 (its STL's volume the outline's area times the thickness); optimality criteria
    run it too."""
    common = [plate_toml(tmp_path), "--global-volume", "--volume-fraction", 0.5, "--filter", 0.06, "--projection", 2, "--no-plots"]
    straight, split = tmp_path / "straight", tmp_path / "split"
    flextop_cli("optimize", *common, "--max-iter", 6, "--out", straight, codes=(0, 3))
    flextop_cli("optimize", *common, "--max-iter", 3, "--out", split, codes=(0, 3))
    saved = json.loads((split / "checkpoint.json").read_text())["data"]["problem"]["filter"]
    assert saved == {"kind": "density", "radius": 0.06, "beta": 2.0, "eta": 0.5}
    flextop_cli("optimize", "--resume", "--max-iter", 6, "--out", split, codes=(0, 3))
    np.testing.assert_allclose(np.load(split / "design.npy"), np.load(straight / "design.npy"), rtol=0, atol=1e-12)
    assert [h["f0"] for h in history(split)] == pytest.approx([h["f0"] for h in history(straight)], rel=1e-12)
    sim = flextop.Simulation(flextop.Scene.from_toml(tmp_path / "plate.toml"))
    physical = flextop.problems.DensityFilter(sim, 0.06, beta=2.0).physical(np.load(straight / "design.npy"))
    np.testing.assert_allclose(np.load(straight / "densities.npy"), physical, rtol=0, atol=1e-15)
    stl = pytest.importorskip("stl")
    shape = flextop.io.cad.outline(sim, np.load(straight / "densities.npy"))
    volume = stl.mesh.Mesh.from_file(straight / "cad" / "plate.stl").get_mass_properties()[0]
    assert volume == pytest.approx(shape.area * 0.01 * 1e9, rel=1e-7) and shape.area > 0.1 * 0.6 * 0.2
    assert (straight / "cad" / "plate.dxf").stat().st_size > 1000 and (straight / "cad" / "plate.svg").stat().st_size > 1000
    oc = flextop_cli("optimize", *common, "--method", "oc", "--max-iter", 3, "--out", tmp_path / "oc", codes=(0, 3))
    assert "(oc)" in oc.stdout and "compliance" in oc.stdout


def test_optimality_criteria_converge_on_the_88_line_codes_stop_and_exit_0(tmp_path):
    """OC on the plate's compliance with the 88-line code's stop (``--xtol 0.01``): converged
    on its design change (FIXED_POINT) long before the iteration limit, exit 0, and a
    converged run that a resume refuses; without the stop, the iteration limit and exit 3."""
    common = [plate_toml(tmp_path), "--global-volume", "--volume-fraction", 0.5, "--filter", 0.06, "--method", "oc", "--no-plots"]
    run = flextop_cli("optimize", *common, "--xtol", 0.01, "--max-iter", 150, "--out", tmp_path / "xtol")
    assert "status: FIXED_POINT — converged: the update's max design change" in run.stdout and "did not converge" not in run.stderr
    assert len(history(tmp_path / "xtol")) < 150
    resumed = flextop_cli("optimize", "--resume", "--max-iter", 200, "--out", tmp_path / "xtol", codes=(2,))
    assert "has converged (FIXED_POINT)" in resumed.stderr
    limited = flextop_cli("optimize", *common, "--max-iter", 5, "--out", tmp_path / "limited", codes=(3,))
    assert "did not converge: maximum number of iterations (5) reached" in limited.stderr


def test_optimize_robot_arm_writes_the_pictures(tmp_path):
    run = flextop_cli("optimize", "robot_arm", "--max-iter", 3, "--out", tmp_path, "--animate", codes=(3,))
    assert "did not converge: maximum number of iterations (3) reached" in run.stderr
    for name in ("design_initial.png", "design.png", "history.png", "tip_error.png", "motion.gif"):
        assert (tmp_path / name).stat().st_size > 1000, name
    assert re.search(r"tip_deflection: 0\.00229569 at the start → [0-9.e-]+ \(-\d+\.\d %\)", run.stdout)
    assert "subproblem" in run.stdout and "simulation" in run.stdout


def test_the_readme_s_continuum_commands_run_as_written(tmp_path):
    """Every scene file the README's commands name exists, and its continuum optimizations
    (the half-MBB in steel and in the 88-line code's units, the cantilever, the continuum arm
    sized by --cells) run as written, cut
    to two iterations into a folder of their own: a design and the members' CAD files."""
    block = re.search(r"## Command line\n\n```bash\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)[1]
    named = set(re.findall(r"examples/\S+\.toml", block))
    assert named and all((ROOT / path).is_file() for path in named), named
    commands = [shlex.split(line) for line in block.splitlines() if re.search(r"flextop optimize \S*(mbb|cantilever|continuum)", line)]
    assert len(commands) == 4
    for k, argv in enumerate(commands):
        out = tmp_path / f"run{k}"
        argv = [out if before == "--out" else 2 if before == "--max-iter" else a for before, a in zip(["", *argv], argv)]
        run = subprocess.run([sys.executable, "-m", "flextop.cli", *map(str, argv[1:]), "--no-plots"], capture_output=True,
                             text=True, timeout=600, cwd=ROOT)
        assert run.returncode in (0, 3), run.stderr
        assert len(history(out)) == 3 and np.load(out / "design.npy").size > 100  # the start and two iterations
        assert list((out / "cad").glob("*.stl")), run.stdout


USER_ERRORS = [
    (["simulate", "{tmp}/bad.toml"], "bad.toml: not valid TOML: Illegal character '\\n' (at line 1, column 10)"),
    (["simulate", "{tmp}/latin1.toml"], "latin1.toml: not UTF-8 text (byte 8)"),
    (["simulate", "{tmp}"], "cannot read: Is a directory"),
    (["simulate", "no-such-scene"], "nor a built-in scene (robot_arm, static_truss, spun_beam, ten_bar_truss, pendulum, slider_crank, four_bar, "
                                           "continuum_robot_arm, continuum_slider_crank, half_mbb, continuum_cantilever)"),
    (["simulate", "robot_arm", "--design", "{tmp}/latin1.toml"], "cannot read a design vector"),
    (["simulate", "robot_arm", "--out", "{tmp}/bad.toml"], "a file of that name exists"),
    (["optimize", "static_truss", "--volume-fraction", "0"], "argument --volume-fraction: 0 must be above 0"),
    (["optimize", "static_truss", "--max-iter", "-5"], "argument --max-iter: -5 must be above 0"),
    (["optimize", "static_truss", "--move", "-1"], "argument --move: -1 must be above 0"),
    (["optimize", "robot-arm"], "no such scene file, nor a built-in scene"),
    (["optimize", "static_truss", "--projection", "4"], "--projection sharpens the density filter's densities: give --filter RADIUS too"),
    (["optimize", "static_truss", "--filter", "0.1"], "--filter acts on continuum members' cells, and the scene designs none"),
    (["optimize", "static_truss", "--cad-threshold", "1"], "argument --cad-threshold: 1 must be in (0, 1)"),
    (["optimize", "static_truss", "--filter-cells", "2"], "--filter-cells acts on continuum members' cells, and the scene designs none"),
    (["optimize", "half_mbb", "--filter", "0.02", "--filter-cells", "2"], "give the filter's radius in m (--filter) or in cells"),
    (["optimize", "robot_arm", "--cells", "20x6"], "--cells sizes the members of a built-in continuum scene"),
    (["simulate", "continuum_robot_arm", "--cells", "20x5"], "continuum_robot_arm: ny must be even"),
    (["simulate", "continuum_robot_arm", "--cells", "20"], "argument --cells: '20' is not NXxNY"),
]


def cli(argv):
    """``flextop.cli.main(argv)`` in this process: its exit code, argparse's included."""
    try:
        return flextop.cli.main([str(a) for a in argv])
    except SystemExit as stop:
        return stop.code


@pytest.mark.parametrize("argv, message", USER_ERRORS)
def test_user_errors_are_one_line_and_exit_2(tmp_path, capsys, argv, message):
    (tmp_path / "bad.toml").write_text('name = "x\n')
    (tmp_path / "latin1.toml").write_bytes('name = "é"\n'.encode("latin-1"))
    assert cli([a.format(tmp=tmp_path) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    last = err.splitlines()[-1]
    assert message in last and "Traceback" not in err, err
    assert err.count("\n") == 0 or err.startswith("usage:"), err  # argparse adds its usage line before


def test_x0_outside_the_bounds_is_a_named_user_error(tmp_path, capsys):
    assert cli(["optimize", "static_truss", "--x0", "2", "--no-plots", "--out", tmp_path]) == 2
    assert "outside [0.01, 1]" in capsys.readouterr().err


def test_a_scene_file_with_a_byte_order_mark_reads_like_one_without(tmp_path):
    text = flextop.scenes.example_toml("static_truss.toml")
    (tmp_path / "bom.toml").write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert flextop.Scene.from_toml(tmp_path / "bom.toml").to_dict() == flextop.Scene.from_toml(EXAMPLES / "static_truss.toml").to_dict()
    (tmp_path / "deep.toml").write_text("a = " + "[" * 2000 + "]" * 2000)
    with pytest.raises(flextop.SceneFileError, match="nested too deeply"):
        flextop.Scene.from_toml(tmp_path / "deep.toml")


def test_resume_verifies_the_checkpoint(tmp_path, capsys):
    out = tmp_path / "run"
    assert flextop.cli.main(["optimize", "static_truss", "--objective", "compliance", "--max-iter", "3", "--out", str(out), "--no-plots"]) == 3
    sealed = json.loads((out / "checkpoint.json").read_text())
    assert sealed["data"]["finished"] == "MAX_ITER"

    def resume(data, *extra, seal=True):
        copy = json.loads(json.dumps(sealed))
        copy["data"] = data
        if seal:
            copy["sha256"] = flextop.io.checkpoint._digest(data)
        (out / "checkpoint.json").write_text(json.dumps(copy))
        code = flextop.cli.main(["optimize", "--resume", "--out", str(out), "--no-plots", *extra])
        return code, capsys.readouterr().err.strip().splitlines()[-1]

    data = sealed["data"]
    outside = json.loads(json.dumps(data))
    outside["state"]["x"][0] = 2.0
    assert resume(outside, "--max-iter", "5", seal=False) == (2, f"flextop: error: {out / 'checkpoint.json'} is corrupt: its contents do not match their checksum")
    assert "holds a design outside the bounds [0.01, 1]" in resume(outside, "--max-iter", "5")[1]
    assert "has done its 3 iterations; give --max-iter above that" in resume(data)[1]
    assert "--method gcmma differs from the checkpoint's mma" in resume(data, "--max-iter", "5", "--method", "gcmma")[1]
    converged = {**data, "finished": "KKT"}
    assert "has converged (KKT); there is nothing to resume" in resume(converged, "--max-iter", "5")[1]
    (out / "checkpoint.json").write_text("{not json")
    assert flextop.cli.main(["optimize", "--resume", "--out", str(out)]) == 2
    assert "cannot be read as a checkpoint" in capsys.readouterr().err


def test_resume_refuses_flags_the_checkpoint_fixes_and_a_shortened_step_is_reported(tmp_path):
    flextop_cli("optimize", "static_truss", "--max-iter", 1, "--out", tmp_path, "--no-plots", codes=(3,))
    run = flextop_cli("optimize", "--resume", "--max-iter", 2, "--volume-fraction", 0.3, "--h", 0.01, "--out", tmp_path, check=False)
    assert run.returncode == 2 and "--volume-fraction, --h: the checkpoint fixes the problem" in run.stderr
    short = flextop_cli("simulate", "robot_arm", "--x", 0.4, "--h", 0.5)
    assert short.stderr.strip() == "flextop: warning: h = 0.5 s was shortened to 0.433333 s so that a whole number of steps ends at t_end"
    assert "3 steps of h = 0.433333 s" in short.stdout


def test_results_print_as_one_line(arm):
    res = arm.run(0.4)
    assert repr(res) == "Results(robot_arm: 65 steps to t = 1.3 s; x in [0.4, 0.4] (148 values))"
    with pytest.warns(flextop.errors.SettingsWarning, match="shortened to 0.433333 s"):
        arm.run(0.4, h=0.5)


def test_a_start_design_that_cannot_be_evaluated_ends_with_its_reason(tmp_path):
    scene = flextop.scenes.static_truss(force=(0.0, -1e12))
    (tmp_path / "huge.toml").write_text(scene.to_toml())
    run = flextop_cli("optimize", tmp_path / "huge.toml", "--max-iter", 2, "--no-plots", "--out", tmp_path / "out", codes=(3,))
    assert "status: EVALUATION_FAILED" in run.stdout and "Traceback" not in run.stderr
    lone = flextop_cli("optimize", "static_truss", "--aggregate", "worst", "--workers", 2, "--out", tmp_path / "x", check=False)
    assert lone.returncode == 2 and "--aggregate, --workers: for several scenarios" in lone.stderr


def test_a_frequency_floor_from_the_command_line(tmp_path):
    """--min-frequency adds the floor, shown as >= with its value in Hz at the end; it is
    fixed by a checkpoint and applies to one scene only."""
    run = flextop_cli("optimize", "static_truss", "--min-frequency", "1.5", "--max-iter", 2, "--out", tmp_path, "--no-plots",
                      codes=(0, 3))
    assert "min_frequency >= 1.5" in run.stdout
    value = float(re.search(r"^min_frequency: (\S+) \(>= 1\.5\)$", run.stdout, re.M).group(1))
    assert value > 0
    resumed = flextop_cli("optimize", "--resume", "--min-frequency", "2", "--out", tmp_path, codes=(2,))
    assert "--min-frequency" in resumed.stderr
    mixed = flextop_cli("optimize", "--scenarios", "robust_robot_arm", "--min-frequency", "2", "--out", tmp_path / "s", codes=(2,))
    assert mixed.stderr.strip() == "flextop: error: --min-frequency applies to one scene, not to --scenarios"


def test_stress_and_buckling_limits_from_the_command_line(tmp_path):
    """--max-stress and --max-buckling add limits on the peaks (normalized means), shown as
    <= with their values; a checkpoint fixes them and they apply to one scene only."""
    run = flextop_cli("optimize", "static_truss", "--max-stress", "4e8", "--max-buckling", "0.5", "--max-iter", 3,
                      "--out", tmp_path, "--no-plots", codes=(0, 3))
    stress = float(re.search(r"^stress: (\S+) \(<= 4e\+08\)$", run.stdout, re.M).group(1))
    buckling = float(re.search(r"^buckling: (\S+) \(<= 0\.5\)$", run.stdout, re.M).group(1))
    design = np.load(tmp_path / "design.npy")
    peaks = flextop.Simulation(flextop.scenes.static_truss()).run_with_sensitivities(design, ["stress", "buckling"]).peaks
    # c P with c from the previous iteration: within a few per cent of the peak at the end.
    assert stress == pytest.approx(peaks["stress"], rel=0.1) and buckling == pytest.approx(peaks["buckling"], rel=0.1)
    resumed = flextop_cli("optimize", "--resume", "--max-stress", "1e8", "--out", tmp_path, codes=(2,))
    assert "--max-stress" in resumed.stderr
    mixed = flextop_cli("optimize", "--scenarios", "robust_robot_arm", "--max-buckling", "1", "--out", tmp_path / "s", codes=(2,))
    assert mixed.stderr.strip() == "flextop: error: --max-buckling applies to one scene, not to --scenarios"


def test_a_von_mises_limit_from_the_command_line(tmp_path):
    """--max-stress on a scene of continuum members said their stresses were "not built
    yet"; it names ``von_mises``, and --max-von-mises limits that peak, shown as <= with its
    value."""
    wrong = flextop_cli("optimize", "continuum_slider_crank", "--max-stress", "1e8", "--max-iter", 1, "--out", tmp_path / "s",
                        "--no-plots", codes=(2,))
    assert "`von_mises`" in wrong.stderr and "not built yet" not in wrong.stderr, wrong.stderr
    run = flextop_cli("optimize", "continuum_slider_crank", "--max-von-mises", "1e8", "--max-iter", 1, "--out", tmp_path / "v",
                      "--no-plots", codes=(0, 3))
    assert re.search(r"^von_mises: \S+ \(<= 1e\+08\)$", run.stdout, re.M), run.stdout
    resumed = flextop_cli("optimize", "--resume", "--max-von-mises", "1e7", "--out", tmp_path / "v", codes=(2,))
    assert "--max-von-mises" in resumed.stderr


def test_a_new_run_does_not_replace_an_earlier_checkpoint_without_force(tmp_path, capsys):
    """A new `flextop optimize` into a folder holding an interrupted, resumable run replaced
    its checkpoint."""
    from flextop import cli

    assert cli.main(["optimize", "static_truss", "--max-iter", "2", "--no-plots", "--out", str(tmp_path)]) == 3  # not converged
    saved = (tmp_path / "checkpoint.json").read_bytes()
    capsys.readouterr()
    assert cli.main(["optimize", "static_truss", "--max-iter", "3", "--no-plots", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "holds a run that can be resumed from iteration 2 (--resume goes on with it)" in err
    assert (tmp_path / "checkpoint.json").read_bytes() == saved
    assert cli.main(["optimize", "static_truss", "--max-iter", "3", "--no-plots", "--out", str(tmp_path), "--force"]) == 3
    assert (tmp_path / "checkpoint.json").read_bytes() != saved


def test_simulate_runs_a_spatial_scene_and_refuses_what_it_does_not_take(tmp_path):
    out = flextop_cli("simulate", str(EXAMPLES / "spatial_slider_crank.toml"), "--t-end", "0.2", "--out", tmp_path)
    frames = len(flextop.io.export.frame_indices(201))  # about 100 of the 201 states
    assert (tmp_path / "motion.pvd").exists() and len(list(tmp_path.glob("motion_*.vtu"))) == frames == 68
    assert "200 steps to t = 0.2 s" in out.stdout
    slider = [float(v) for v in re.search(r"'slider' at \[([^\]]*)\] m", out.stdout).group(1).split()]
    assert 0.15 < slider[0] < 0.45 and max(map(abs, slider[1:])) < 1e-12
    refused = flextop_cli("simulate", str(EXAMPLES / "heavy_top.toml"), "--local-tol", "0.01", codes=(2,))
    assert refused.stderr.strip() == ("flextop: error: --local-tol: not built for spatial scenes yet "
                                      "(they take --x, --design, --t-end, --h, --rho-inf, --accuracy, --rtol, --out)")
    # a design: every bar of the spatial robot arm at one density, or a vector from a file
    arm = str(EXAMPLES / "spatial_robot_arm.toml")
    light, full = (flextop_cli("simulate", arm, "--t-end", "0.1", *x).stdout for x in (["--x", "0.2"], []))
    assert light.split("\n")[1:] != full.split("\n")[1:] and "10 steps to t = 0.1 s" in light  # lighter: other energies
    np.savetxt(tmp_path / "x.txt", np.full(188, 0.2))
    designed = flextop_cli("simulate", arm, "--t-end", "0.1", "--design", tmp_path / "x.txt", "--out", tmp_path / "arm")
    assert designed.stdout.split("\n")[1:3] == light.split("\n")[1:3]
    assert (tmp_path / "arm" / "design.png").stat().st_size > 10_000 and "design.png" in designed.stdout
    bad = flextop_cli("simulate", arm, "--t-end", "0.1", "--x", "1.5", codes=(2,))
    assert bad.stderr.count("\n") == 1 and "is outside [0.01, 1]" in bad.stderr
    # to a tolerance: the tip's deflection with the grid chosen and its estimated error, within it
    tol = flextop_cli("simulate", arm, "--t-end", "0.2", "--rtol", "0.1").stdout
    found = re.search(r"tip_deflection = (\S+) m² to rtol = 0.1 in \S+ s: .* and (\d+) steps; estimated relative error (\S+)%", tol)
    assert found and int(found.group(2)) > 20 and float(found.group(3)) <= 10.0, tol
    both = flextop_cli("simulate", arm, "--rtol", "0.1", "--h", "0.01", codes=(2,))
    assert both.stderr.strip() == "flextop: error: give --h (a fixed step) or --rtol/--accuracy (steps chosen to meet it), not both"


def test_simulate_writes_a_spatial_equilibrium_and_a_run_to_a_tolerance_for_paraview(tmp_path):
    """A static spatial scene's ``--out``: its state (points where the scene puts them, the
    displacement to the equilibrium: the loaded end's what the equilibrium gives) and its
    design; a run to a tolerance's: the motion on the grid it accepted (its steps' frames)."""
    import meshio

    scene = lattice_cantilever()
    (tmp_path / "lattice.toml").write_text(scene.to_toml())
    out = flextop_cli("simulate", tmp_path / "lattice.toml", "--x", "0.5", "--out", tmp_path / "static")
    assert "state.vtu" in out.stdout and (tmp_path / "static" / "design.png").stat().st_size > 10_000
    mesh = meshio.read(tmp_path / "static" / "state.vtu")
    sim = flextop.SpatialSimulation(scene)
    eq = sim.equilibrium(0.5)
    k = sim.layout.node("box[3,0,0]")
    assert np.allclose(mesh.points[k], np.asarray(sim.model.initial_q).reshape(-1, 7)[k, :3], atol=1e-12)
    assert np.allclose(mesh.point_data["displacement"][k], eq.position("box[3,0,0]") - mesh.points[k], atol=1e-12)
    assert mesh.point_data["displacement"][k][1] < -1e-5  # pushed down
    arm = str(EXAMPLES / "spatial_robot_arm.toml")
    tol = flextop_cli("simulate", arm, "--t-end", "0.2", "--rtol", "0.1", "--out", tmp_path / "tol")
    steps = int(re.search(r"and (\d+) steps", tol.stdout).group(1))
    assert "on the grid accepted" in tol.stdout
    frames = len(flextop.io.export.frame_indices(steps + 1))
    assert len(list((tmp_path / "tol").glob("motion_*.vtu"))) == frames


def test_optimize_designs_a_spatial_scene_and_refuses_what_it_does_not_take(tmp_path):
    """A spatial lattice cantilever's strain energy at 30 % of its volume: the command
    converges to the KKT point the Python problem reaches (18 iterations, residual below
    1e-4, the energy 0.045 of the start's) and writes the design, its history and figures;
    the spatial robot arm's default objective is its tip's deflection from the rigid
    trajectory, a run stopped at --max-iter exits 3; planar-only options are named."""
    scene = lattice_cantilever()
    (tmp_path / "lattice.toml").write_text(scene.to_toml())
    out = tmp_path / "lattice"
    run = flextop_cli("optimize", tmp_path / "lattice.toml", "--volume-fraction", "0.3", "--x0", "0.3", "--max-iter", "100",
                      "--kkt-tol", "1e-4", "--out", out)
    assert "status: KKT" in run.stdout and "minimize strain_energy over 72 densities" in run.stdout
    ratio = float(re.search(r"\(([-+.\d]+) %\) after (\d+) iterations", run.stdout).group(1))
    assert -96.0 < ratio < -90.0
    sim = flextop.SpatialSimulation(scene)
    x = np.load(out / "design.npy")
    assert x.shape == (72,) and sim.volume(x) <= 0.3 * sim.volume(1.0) * (1 + 1e-9)
    assert all((out / name).stat().st_size > 1000 for name in ("design.png", "history.png", "history.json"))
    arm = flextop_cli("optimize", EXAMPLES / "spatial_robot_arm.toml", "--max-iter", "1", "--t-end", "0.2",
                      "--out", tmp_path / "arm", codes=(3,))
    assert "minimize tip_deflection over 188 densities" in arm.stdout and "after 1 iterations" in arm.stdout
    refused = flextop_cli("optimize", tmp_path / "lattice.toml", "--filter", "0.01", "--out", tmp_path / "x", codes=(2,))
    assert refused.stderr.count("\n") == 1 and refused.stderr.startswith("flextop: error: --filter: not built for spatial scenes yet")
    # held to a tolerance: the same KKT point, the design returned measured to it
    held = flextop_cli("optimize", tmp_path / "lattice.toml", "--volume-fraction", "0.3", "--x0", "0.3", "--max-iter", "100",
                       "--kkt-tol", "1e-4", "--rtol", "0.01", "--out", tmp_path / "held")
    assert "status: KKT" in held.stdout and "to rtol = 0.01: the design returned measured on" in held.stdout
    assert sim.run_with_sensitivities(np.load(tmp_path / "held" / "design.npy"), "strain_energy", rtol=0.01).errors["strain_energy"] <= 0.01
    both = flextop_cli("optimize", tmp_path / "lattice.toml", "--rtol", "0.01", "--h", "0.01", "--out", tmp_path / "y", codes=(2,))
    assert "give --h (a fixed step) or --rtol/--accuracy" in both.stderr

"""Saved results: save → load gives back every field bit for bit; the xarray view."""

import numpy as np
import pytest

import flextop
from flextop.io import saved


def same(a, b):
    assert type(a) is type(b)
    assert a.raw.keys() == b.raw.keys()
    for key in a.raw:
        assert np.array_equal(np.asarray(a.raw[key]), np.asarray(b.raw[key])), key
        assert np.asarray(a.raw[key]).dtype == np.asarray(b.raw[key]).dtype, key
    assert (a.x is None and b.x is None) or (np.array_equal(a.x, b.x) and a.x.dtype == b.x.dtype)
    assert a.settings == b.settings and a.discretization == b.discretization and a.errors == b.errors
    assert a.simulation.spec == b.simulation.spec and a.simulation.options == b.simulation.options


def test_save_and_load_give_back_every_field(tmp_path, arm):
    runs = [arm.run(np.random.default_rng(0).uniform(0.05, 1.0, arm.n_design), h=0.01, rho_inf=0.6),
            arm.run(0.4, rtol=1e-2),  # from the refined scene the tolerance chose, with its estimate
            flextop.Simulation(flextop.scenes.static_truss()).run(0.3),
            flextop.Simulation(flextop.scenes.spun_beam(), accuracy="fast").run()]
    for k, res in enumerate(runs):
        back = flextop.load(res.save(tmp_path / f"run{k}.npz"))
        same(res, back)
        if isinstance(res, flextop.Results):
            assert back.tip_deflection() == res.tip_deflection()
            assert back.motor_torques.keys() == res.motor_torques.keys()
            assert all(np.array_equal(back.motor_torques[j], t) for j, t in res.motor_torques.items())


def test_results_save_into_a_new_directory(tmp_path):
    res = flextop.Simulation(flextop.scenes.static_truss()).run(0.3)
    same(res, flextop.load(res.save(tmp_path / "not" / "yet" / "there.npz")))


def test_the_file_describes_itself_without_flextop(tmp_path, arm):
    res = arm.run(0.4)
    with np.load(res.save(tmp_path / "arm.npz")) as data:
        import json

        meta = json.loads(str(data["meta"]))
        assert data["q"].shape == (66, 90) and data["x"].shape == (148,)
        data_q = data["q"].reshape(66, -1, 3)
    assert meta["node_names"] == arm.node_names and meta["variable_names"] == arm.variable_names
    positions = np.asarray(meta["reference_positions"]) + data_q[:, :, :2]
    assert np.array_equal(positions, res.positions)
    assert meta["multipliers"] == ["shoulder:x", "shoulder:y", "shoulder:drive", "elbow:x", "elbow:y", "elbow:drive"]
    assert [j["name"] for j in meta["joints"]] == ["shoulder", "elbow"] and len(meta["bars"]["name"]) == 148


def test_bad_files_are_named(tmp_path):
    with pytest.raises(flextop.SettingsError, match="not a file of saved flextop results"):
        flextop.load(tmp_path / "missing.npz")
    np.savez(tmp_path / "other.npz", q=np.zeros(3))
    with pytest.raises(flextop.SettingsError, match="other.npz: not a file of saved flextop results"):
        flextop.load(tmp_path / "other.npz")
    # A damaged file (BadZipFile before), a truncated one and one whose description lacks parts.
    (tmp_path / "damaged.npz").write_bytes(b"PK\x03\x04garbage")
    with pytest.raises(flextop.SettingsError, match="damaged.npz: .*damaged one \\(BadZipFile"):
        flextop.load(tmp_path / "damaged.npz")
    good = flextop.Simulation(flextop.scenes.static_truss()).run(0.4).save(tmp_path / "good.npz")
    (tmp_path / "cut.npz").write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(flextop.SettingsError, match="cut.npz: not a file of saved flextop results"):
        flextop.load(tmp_path / "cut.npz")
    np.savez(tmp_path / "partial.npz", meta=np.array('{"version": 1}'))
    with pytest.raises(flextop.SettingsError, match="partial.npz: .*KeyError"):
        flextop.load(tmp_path / "partial.npz")


@pytest.mark.parametrize("rtol", [None, 5e-2])
def test_sensitivities_save_and_load_bit_for_bit(tmp_path, rtol):
    """Sensitivities had no save; now every field comes back bit for bit."""
    sim = flextop.Simulation(flextop.scenes.spun_beam())
    sens = sim.run_with_sensitivities(0.5, ["tip_deflection", "volume", "stress"], rtol=rtol, parameters=["E:aluminium"])
    back = flextop.load(sens.save(tmp_path / "s.npz"))
    assert isinstance(back, flextop.Sensitivities)
    for field in ("values", "gradients", "parameter_gradients"):
        assert np.array_equal(getattr(back, field), getattr(sens, field))
    assert (back.names, back.method, back.timings, back.discretization, back.errors, back.gradient_errors, back.peaks,
            back.parameters, back.peak_errors) == (sens.names, sens.method, sens.timings, sens.discretization, sens.errors,
                                                   sens.gradient_errors, sens.peaks, sens.parameters, sens.peak_errors)
    assert bool(sens.peak_errors) == (rtol is not None)
    assert (back.steps is None) == (sens.steps is None)


def test_the_xarray_view(arm):
    xr = pytest.importorskip("xarray")
    res = arm.run(0.4)
    ds = res.to_xarray()
    assert isinstance(ds, xr.Dataset)
    assert ds["q"].dims == ("time", "node", "coordinate") and list(ds.coordinate.values) == ["x", "y", "phi"]
    tip = arm.node_names[arm.tip]
    assert np.array_equal(ds["q"].sel(node=tip).values, res.q.reshape(len(res.time), -1, 3)[:, arm.tip])
    assert np.array_equal(ds["lam"].sel(multiplier="elbow:drive").values, res.motor_torques["elbow"] * -1)
    assert list(ds.multiplier.values) == saved.multiplier_names(arm)

"""Models: load, parse, write back, named accessors, generators with the
CLI's defaults, analyze, and the errors bad inputs raise."""

import json
import pickle

import numpy as np
import pytest

import truss_deploy as td
from conftest import BUNDLED, MODELS


@pytest.mark.parametrize("name", BUNDLED)
def test_a_bundled_model_writes_back_its_own_file(name):
    path = MODELS / f"{name}.toml"
    m = td.load(path)
    assert m.to_toml() == path.read_text()
    assert m.source == str(path)
    assert m.positions().shape == (len(m.joint_names), 3)


def test_parse_save_and_pickle(tmp_path):
    text = (MODELS / "pantograph_mast.toml").read_text()
    m = td.parse(text, "mast.toml")
    out = tmp_path / "m.toml"
    m.save(out)
    assert td.load(out).to_toml() == text
    back = pickle.loads(pickle.dumps(m))
    assert back.to_toml() == text and back.source == "mast.toml"


def test_named_accessors_change_the_model_and_are_checked():
    m = td.load(MODELS / "pantograph_mast.toml")
    assert m.joint_mass("L0") == 0.15
    assert m.set_joint_mass("L*", 0.2) == 5
    assert m.joint_mass("L3") == 0.2 and m.joint_mass("R3") == 0.15
    m.set_cable_tension("drive", 0.03)
    m.set_cable_mu("drive", 0.01)
    assert (m.cable_tension("drive"), m.cable_mu("drive")) == (0.03, 0.01)
    assert m.member_stiffness("U1") == 6.0e6
    m.set_member_stiffness("U*", 2.0e6)
    assert m.member_stiffness("U2") == 2.0e6
    assert m.latch_stiffness("S1") == 200000.0 and m.latch_damping("S1") == 300.0
    m.set_latch_stiffness("S*", 1.0e5, 50.0)
    assert m.latch_stiffness("S4") == 1.0e5 and m.latch_damping("S4") == 50.0
    m.set_latch_stiffness("S1", None)
    assert m.latch_stiffness("S1") is None
    m.dt_s = 0.02
    text = m.to_toml()
    assert "axial_stiffness_n = 2000000.0" in text and "mass_kg = 0.2" in text
    # the edited model is a model: it loads and runs
    again = td.parse(text)
    assert again.cable_tension("drive") == 0.03 and again.dt_s == 0.02
    # what the loader refuses changes nothing
    with pytest.raises(td.ModelError, match="max_tension_n"):
        m.set_cable_tension("drive", 5.0)
    assert m.cable_tension("drive") == 0.03
    with pytest.raises(ValueError, match="mass_kg"):
        m.set_joint_mass("L0", -1.0)
    with pytest.raises(KeyError, match="no joint `Q9`"):
        m.set_joint_mass("Q9", 1.0)
    with pytest.raises(ValueError, match="not a sleeve"):
        m.latch_stiffness("U1")
    with pytest.raises(KeyError, match="no parameter"):
        m.set_element_param("U1", "lock_length_m", 1.0)
    assert m.element_param("U1", "ratio") == 1.0


def test_generators_have_the_cli_defaults_and_checks(cli, tmp_path):
    for kind, kwargs, flags in [
        ("mast", {}, []),
        ("mast", {"units": 6, "mu": 0.01, "latch_stiffness": 1e5}, ["--units", "6", "--mu", "0.01", "--latch-stiffness", "100000"]),
        ("ring", {"sides": 12, "mu": 0.02}, ["--sides", "12", "--mu", "0.02"]),
        ("ring", {"sync": True, "sides": 12}, ["--sync", "--sides", "12"]),
        ("sail", {"bays": 2}, ["--bays", "2"]),
    ]:
        out = tmp_path / f"{kind}.toml"
        cli("generate", kind, *flags, "-o", out)
        m = getattr(td.generate, kind)(**kwargs)
        assert m.to_toml() == out.read_text(), (kind, kwargs)
    with pytest.raises(ValueError, match="sides"):
        td.generate.ring(sides=3)
    with pytest.raises(ValueError, match="--latch-damping needs --latch-stiffness"):
        td.generate.mast(latch_damping=5.0)
    with pytest.raises(TypeError):
        td.generate.mast(sides=12)


@pytest.mark.parametrize("name", ["pantograph_mast", "sail_array"])
def test_analyze_is_the_cli_report(cli, tmp_path, name):
    out = tmp_path / "a.json"
    cli("analyze", MODELS / f"{name}.toml", "--json", out)
    assert td.load(MODELS / f"{name}.toml").analyze() == json.loads(out.read_text())


def test_a_ring_on_a_bus_is_the_clis(cli, tmp_path):
    out = tmp_path / "bus.toml"
    cli("generate", "ring", "--sides", "12", "--mount", "bus", "--bus-mass-kg", "250", "--bus-inertia", "40,55,70", "-o", out)
    m = td.generate.ring(sides=12, mount="bus", bus_mass_kg=250.0, bus_inertia=(40, 55, 70))
    assert m.to_toml() == out.read_text()
    assert sum(m.joint_mass(n) for n in m.joint_names if n.startswith("BUS_")) == pytest.approx(250.0, rel=1e-12)


def test_modes_are_the_cli_modes(cli, tmp_path):
    out = tmp_path / "m.json"
    cli("analyze", MODELS / "double_ring.toml", "--modes", "4", "--json", out)
    modes = td.load(MODELS / "double_ring.toml").modes(4)
    assert modes == json.loads(out.read_text())["modes"]
    assert [m["kind"] for m in modes["modes"]] == ["elastic"] * 4
    with pytest.raises(ValueError, match="at least one mode"):
        td.load(MODELS / "double_ring.toml").modes(0)


def test_a_malformed_model_names_the_file_the_line_and_the_key(tmp_path, cli):
    text = (MODELS / "pantograph_mast.toml").read_text().replace("mass_kg = 0.15", 'mass_kg = "heavy"', 1)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(td.ModelError) as e:
        td.load(bad)
    line = text.splitlines().index('mass_kg = "heavy"') + 1
    assert e.value.file == str(bad) and e.value.line == line
    assert str(e.value).startswith(f"{bad}:{line}: `mass_kg`")
    # the CLI's message, word for word
    p = cli("simulate", bad, check=False)
    assert p.returncode == 2 and p.stderr.strip() == f"error: {e.value}"
    with pytest.raises(td.ModelError, match="cannot read the model file"):
        td.load(tmp_path / "missing.toml")
    assert issubclass(td.ModelError, td.TrussDeployError)
    assert isinstance(e.value, td.TrussDeployError)
    with pytest.raises(td.ModelError, match=r"<string>:\d+: .*joint `nowhere`"):
        td.parse(text.replace('mass_kg = "heavy"', "mass_kg = 0.15").replace('path = ["L0"', 'path = ["nowhere"'))

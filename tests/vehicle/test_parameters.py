"""Vehicle parameter files: units converted, sources kept, bad names and values refused."""

import math

import pytest

from trackdyn.errors import TrackdynInputError
from trackdyn.limits import VEHICLE
from trackdyn.vehicle.parameters import PARAMETERS, load_vehicle


def test_loaded_preset_in_si_units():
    v = load_vehicle("loaded")
    assert v.k1 == pytest.approx(4.0e6)  # "4.0 MN/m" in the file
    assert v.x_ss == pytest.approx(0.045)  # "45 mm"
    assert v.alpha_w == pytest.approx(math.radians(36.3))  # "36.3 deg"
    # 26 t axle load: static wheel load = 13 t x g (loaded preset totals 104 t)
    assert v.static_wheel_load == pytest.approx(13000 * 9.81, rel=1e-4)
    assert set(v.sources) == set(PARAMETERS)
    assert "MBSim" in v.sources["mw1"]


def test_base_file_and_overrides(tmp_path):
    f = tmp_path / "wagon.toml"
    f.write_text('base = "empty"\n[mu]\nvalue = 0.3\nunit = "-"\nsource = "test bench"\n')
    v = load_vehicle(f, k1=5e6)
    assert v.mu == 0.3 and v.k1 == 5e6 and v.m1 == load_vehicle("empty").m1
    assert v.sources["mu"] == "test bench" and v.sources["k1"] == "override"
    assert load_vehicle("loaded-high-damping").rho1 == pytest.approx(120e3)


def test_base_file_is_relative_to_the_file(tmp_path, monkeypatch):
    (tmp_path / "parent.toml").write_text('base = "empty"\n')
    (tmp_path / "child.toml").write_text('base = "parent.toml"\n')
    monkeypatch.chdir(tmp_path.parent)
    assert load_vehicle(tmp_path / "child.toml").m1 == load_vehicle("empty").m1


def test_a_loop_of_bases_is_refused_in_one_line(tmp_path):
    # a file its own base, and two files each the other's (a RecursionError's traceback
    # before the check)
    (tmp_path / "self.toml").write_text('base = "self.toml"\n')
    (tmp_path / "a.toml").write_text('base = "b.toml"\n')
    (tmp_path / "b.toml").write_text('base = "a.toml"\n')
    for name, loop in (("self", "self.toml -> self.toml"), ("a", "a.toml -> b.toml -> a.toml")):
        with pytest.raises(TrackdynInputError) as err:
            load_vehicle(tmp_path / f"{name}.toml")
        assert str(err.value).endswith(f"makes a loop of bases ({loop})")
        assert "\n" not in str(err.value)
    # the same file twice along different branches is no loop
    (tmp_path / "c.toml").write_text('base = "empty"\n')
    (tmp_path / "d.toml").write_text('base = "c.toml"\n')
    assert load_vehicle(tmp_path / "d.toml").m1 == load_vehicle("empty").m1


def test_replace_refuses_unknown_name():
    with pytest.raises(TrackdynInputError, match="unknown vehicle parameter 'kappa'"):
        load_vehicle("loaded").replace(kappa=1.0)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('base = "loaded"\n[k1]\nvalue = 4\nunit = "kN"\nsource = "x"\n', "unit 'kN' of k1"),
        ('base = "loaded"\n[k1]\nvalue = 4\nunit = "MN/m"\n', "needs value, unit and source"),
        (
            'base = "loaded"\n[kk1]\nvalue = 4\nunit = "MN/m"\nsource = "x"\n',
            "unknown vehicle parameter 'kk1'",
        ),
        ('base = "loaded"\n[k1]\nvalue = "four"\nunit = "MN/m"\nsource = "x"\n', "not a number"),
        (
            'base = "loaded"\n[k1]\nvalue = -4\nunit = "MN/m"\nsource = "x"\n',
            r"k1 is -4e\+06 N/m, outside the plausible",
        ),
        ('base = "loaded"\n[mu]\nvalue = 0.8\nunit = "-"\nsource = "x"\n', "locks the wedge"),
        ('[k1]\nvalue = 4\nunit = "MN/m"\nsource = "x"\n', "missing vehicle parameter"),
        ("k1 = [", "not valid TOML"),
    ],
)
def test_bad_files(tmp_path, text, match):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(TrackdynInputError, match=match) as err:
        load_vehicle(f)
    assert "bad.toml" in str(err.value)


def test_unknown_preset():
    with pytest.raises(TrackdynInputError, match="unknown vehicle preset 'tank'; known:"):
        load_vehicle("tank")


def test_lumped_wheelset_values_are_derived(tmp_path):
    # 5.4.3: the bogie models' wheelset is both wheelsets of a bogie; the files give one
    # wheelset (1778 kg, 1180 kg m^2: MBSim freight wagon example).
    v = load_vehicle("loaded")
    assert (v.mw1, v.Iw1) == (pytest.approx(1778.0), pytest.approx(1180.0))
    assert (v.mw, v.Iw) == (2 * v.mw1, 2 * v.Iw1)
    assert v.replace(mw1=1500.0).mw == 3000.0
    with pytest.raises(TrackdynInputError, match=r"^mw is derived \(.*\): give mw1 instead$"):
        v.replace(mw=3000.0)
    f = tmp_path / "lumped.toml"
    f.write_text('base = "loaded"\n[Iw]\nvalue = 2000\nunit = "kg m^2"\nsource = "x"\n')
    with pytest.raises(TrackdynInputError, match=r"lumped.toml: Iw is derived .*give Iw1"):
        load_vehicle(f)


def test_every_parameter_has_a_plausible_range_holding_the_presets():
    # with a margin of a factor of 2 each side
    assert set(VEHICLE) == set(PARAMETERS)
    for preset in ("loaded", "empty", "loaded-high-damping", "empty-high-damping"):
        for key, value in load_vehicle(preset).as_dict().items():
            lo, hi = VEHICLE[key]
            assert lo <= value / 2 and 2 * value <= hi, (preset, key)

"""The unit registry: the files' units convert as before, names' units are read whole, and
every unit written to netCDF is one UDUNITS reads with the same size."""

import math
import re
from importlib.resources import files

import numpy as np
import pytest
import xarray as xr

from trackdyn.commands.netcdf import to_cf
from trackdyn.deterioration.law_files import load_law
from trackdyn.errors import TrackdynInputError
from trackdyn.units import (
    DEFINITIONS,
    name_unit,
    quantity,
    registry,
    si_factor,
    spelled_unit,
    udunits,
)
from trackdyn.vehicle.parameters import load_vehicle

# The factors of the hand-written table the registry replaced (SI prefixes: k = 1e3,
# M = 1e6, m = 1e-3; t = 1e3 kg; deg = pi/180 rad): the conversions must stay equal to the
# bit, so that every output stays the same.
FORMER = {
    ("kg", "kg"): 1.0,
    ("t", "kg"): 1e3,
    ("kg m^2", "kg m^2"): 1.0,
    ("t m^2", "kg m^2"): 1e3,
    ("N", "N"): 1.0,
    ("kN", "N"): 1e3,
    ("MN", "N"): 1e6,
    ("N/m", "N/m"): 1.0,
    ("kN/m", "N/m"): 1e3,
    ("kN/mm", "N/m"): 1e6,
    ("MN/m", "N/m"): 1e6,
    ("N s/m", "N s/m"): 1.0,
    ("kN s/m", "N s/m"): 1e3,
    ("MN s/m", "N s/m"): 1e6,
    ("m", "m"): 1.0,
    ("mm", "m"): 1e-3,
    ("km", "m"): 1e3,
    ("m/cycle", "m/cycle"): 1.0,
    ("mm/cycle", "m/cycle"): 1e-3,
    ("1/cycle", "1/cycle"): 1.0,
    ("rad", "rad"): 1.0,
    ("deg", "rad"): math.pi / 180,
    ("-", "-"): 1.0,
}


@pytest.mark.parametrize(("units", "factor"), list(FORMER.items()))
def test_factors_are_those_of_the_former_table(units, factor):
    assert si_factor(*units) == factor


def shipped_units() -> set[str]:
    """Every unit a shipped parameter file gives (vehicle presets, settlement laws)."""
    root = files("trackdyn")
    texts = [p.read_text() for p in root.joinpath("vehicle", "presets").iterdir()]
    texts += [p.read_text() for p in root.joinpath("deterioration").iterdir()
              if p.name.endswith(".toml")]  # fmt: skip
    return {u for t in texts for u in re.findall(r'unit *= *"([^"]*)"', t)}


def test_every_shipped_unit_is_in_the_registry():
    found = shipped_units()
    # the presets give masses, inertias, stiffnesses, dampings; the laws mm/cycle and 1/cycle
    assert {"kg", "kg m^2", "MN/m", "kN s/m", "mm/cycle", "1/cycle", "-"} <= found
    for unit in found:
        quantity(unit)


def test_the_registry_is_built_once():
    assert registry() is registry()


@pytest.mark.parametrize(
    ("name", "stem", "unit"),
    [
        # the suffix table wrote "Mt" here: the unit is metres per 100 MGT
        ("tamped_m_per_100_mgt", "tamped", "m/(100 MGT)"),
        ("mean_interval_mgt", "mean_interval", "MGT"),
        ("body_bounce_acc_rms_m_per_s2", "body_bounce_acc_rms", "m/s^2"),
        ("stiffness_kN_per_mm", "stiffness", "kN/mm"),
        ("speed_kmh", "speed", "km/h"),
        ("passages_per_mgt", "passages", "1/MGT"),
        ("cost_per_100_mgt", "cost", "1/(100 MGT)"),
        ("settlement_mm_per_mgt", "settlement", "mm/MGT"),
        ("dyn_load_sd_kN", "dyn_load_sd", "kN"),
        ("k2_min", "k2_min", None),  # no minute in the registry: "min" is a minimum
        ("load_cycles", "load_cycles", None),  # names spell units by symbol, not plural
        ("settlement_share_per_1000_passages", "settlement_share_per_1000_passages", None),
        ("per_mgt", "per_mgt", None),  # "per" with nothing before it: not read in part
        ("mgt", "mgt", None),  # the quantity is at least the first part
    ],
)
def test_names_units_are_read_whole(name, stem, unit):
    assert name_unit(name) == (stem, unit)


def test_a_name_spells_units_by_symbol():
    assert spelled_unit("kN_per_mm") == "kN/mm"
    assert spelled_unit("inch") is None and spelled_unit("metre") is None
    assert spelled_unit("m_per_100") is None  # a number is not a unit


def test_units_written_to_netcdf():
    ds = xr.Dataset(
        {
            "tamped_m_per_100_mgt": ("alternative", np.array([2.5])),
            "mean_interval_mgt": ("alternative", np.array([40.0])),
            "factor": ("alternative", np.array([0.3]), {"units": "-"}),
            "trigger": ("alternative", np.array([1.0]), {"units": "MGT"}),
            "angle": ("alternative", np.array([0.1]), {"units": "deg"}),
        }
    )
    out = to_cf(ds)
    assert out.tamped_m_per_100_mgt.attrs == {
        "units": "m/(100 Mt)",
        "long_name": "length of track tamped per 100 MGT",  # trackdyn.commands.names
    }
    assert out.mean_interval_mgt.attrs["units"] == "Mt"
    assert out.factor.attrs["units"] == "1" and out.trigger.attrs["units"] == "Mt"
    assert out.angle.attrs["units"] == "degree"  # UDUNITS knows no "deg"
    with pytest.raises(ValueError, match="furlong"):
        to_cf(ds.assign(x=("alternative", np.array([1.0]), {"units": "furlong"})))


SI_BASE = {"[length]": "m", "[mass]": "kg", "[time]": "s", "[angle]": "rad", "[cycle]": "1"}
"""UDUNITS unit of each dimension of the registry (a load cycle is a count)."""


def registry_units() -> list[str]:
    """Every unit the registry defines, by symbol, the prefixes on the metre, and some
    compound units."""
    names = [line.split("=")[0].strip() for line in DEFINITIONS.strip().splitlines()]
    symbols = [registry().get_symbol(n) for n in names if not n.endswith("-")]
    return symbols + ["um", "mm", "cm", "km", "Mm", "Gm", "m/(100 MGT)", "kN s/m", "km/h"]


@pytest.mark.parametrize("unit", registry_units())
def test_udunits_reads_each_unit_with_its_size(unit):
    cf_units = pytest.importorskip("cf_units")
    size = quantity(unit)
    base = size.to_root_units()
    si = " ".join(
        f"{SI_BASE[str(dim)]}^{power}" if SI_BASE[str(dim)] != "1" else "1"
        for dim, power in base.dimensionality.items()
    )
    # cf_units converts the written spelling to the SI base units: the same number
    expected = float(base.magnitude)
    got = cf_units.Unit(udunits(unit)).convert(1.0, cf_units.Unit(si or "1"))
    assert got == pytest.approx(expected, rel=1e-12)


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("unit", "why"),
    [
        ("furlong", r"'furlong' is not defined in the unit registry"),  # no imperial units
        ("mm", r"it is a unit of \[length\]"),  # the wrong dimension
        ("kN**", "not a unit expression"),
        ("", "no unit given"),
    ],
)
def test_a_vehicle_unit_error_is_one_line_naming_file_and_key(tmp_path, unit, why):
    path = write(
        tmp_path,
        "v.toml",
        f'base = "loaded"\nkp = {{ value = 3, unit = "{unit}", source = "x" }}\n',
    )
    message = rf"unit '{re.escape(unit)}' of kp does not parse as N/m \({why}\)"
    with pytest.raises(TrackdynInputError, match=message) as err:
        load_vehicle(path)
    assert str(err.value).startswith(f"{path}: ") and "\n" not in str(err.value)


def test_a_law_unit_of_the_wrong_dimension_is_refused(tmp_path):
    path = write(tmp_path, "s.toml", '[power]\nK_s = { value = 1, unit = "kN", source = "x" }\n')
    message = r"s.toml: \[power\]: unit 'kN' of K_s does not parse as m \(it is a unit of"
    with pytest.raises(TrackdynInputError, match=message) as err:
        load_law("power", path)
    assert "\n" not in str(err.value)


def test_units_other_than_the_former_tables_convert(tmp_path):
    # the registry converts any unit of the right dimension: 3 MN/m = 3e6 N/m, 1 t = 1e3 kg
    path = write(
        tmp_path,
        "v.toml",
        'base = "loaded"\nkp = { value = 3000, unit = "kN/m", source = "x" }\n'
        'm1 = { value = 90, unit = "t", source = "x" }\n',
    )
    vehicle = load_vehicle(path)
    assert vehicle.kp == 3e6 and vehicle.m1 == 90e3


def test_a_study_table_gets_its_units_read_whole():
    from trackdyn.studies.runner import SPECTRUM_FREQUENCY, Statistics, gather

    labels = {"pad_stiffness_kN_per_mm": 90.0, "speed_kmh": 60.0}
    stats = Statistics({"dyn_load_max_kN": 12.0}, np.zeros(SPECTRUM_FREQUENCY.size))
    _, ds = gather([(labels, stats)])
    # the last part alone ("mm") was the unit written before
    assert ds.pad_stiffness_kN_per_mm.attrs["units"] == "kN/mm"
    assert ds.speed_kmh.attrs["units"] == "km/h" and ds.dyn_load_max_kN.attrs["units"] == "kN"

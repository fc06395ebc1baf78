"""The ensemble's members run as sections: a member with nothing varied is the
deterministic run to the bit, and members differ where their samples do."""

import numpy as np
import pytest
import xarray as xr

from trackdyn.deterioration import LoopOptions, Traffic, load_law
from trackdyn.deterioration.runs import Section, SectionTask, run_section
from trackdyn.forecast.ensemble import member_tasks, run_ensemble
from trackdyn.forecast.spread import Growth, Lognormal, Members, sample_members
from trackdyn.io import write_geometry, write_supports
from trackdyn.options import RunOptions
from trackdyn.track.synthetic import synthetic_track
from trackdyn.vehicle.parameters import load_vehicle

TRAFFIC = (Traffic(load_vehicle("loaded"), 60.0, 8065.0, "loaded"),)  # 1e6 t / 124 t


@pytest.fixture(scope="module")
def task(tmp_path_factory):
    """A 100 m section, the 4-DOF model, the loaded wagon, 5 MGT."""
    path = tmp_path_factory.mktemp("ensemble")
    trk = synthetic_track(100.0, spectrum="fra5", seed=21)
    write_geometry(trk.geometry, path / "g.csv")
    write_supports(trk.supports, path / "s.csv")
    options = LoopOptions(run=RunOptions(model="4dof"), total_mgt=5.0, snapshot_every_mgt=2.5,
                          segment_length_m=50.0, seed=3)  # fmt: skip
    section = Section("s", str(path / "g.csv"), str(path / "s.csv"))
    return SectionTask(section, TRAFFIC, load_law("power"), options)


def plain(ds):
    ds.attrs = {k: v for k, v in ds.attrs.items() if not k.startswith("time_")
                and k != "section"}  # fmt: skip
    return ds


def test_a_member_with_nothing_varied_is_the_deterministic_run(task):
    same = Members({}, np.zeros(2), fresh_fields=False)  # the section's field, nothing varied
    ((first, second),) = run_ensemble([task], same, workers=1)
    xr.testing.assert_identical(plain(first), plain(run_section(task)))
    xr.testing.assert_identical(plain(second), plain(first))


def test_members_take_their_samples_and_horizons(task):
    members = sample_members(3, 5, task.law, spreads={"K_s": Lognormal(0.3)},
                             growth=Growth(10.0, 0.05, 0.02))  # fmt: skip
    tasks = member_tasks(task, members, Growth(10.0, 0.05, 0.02), horizon_years=0.5)
    assert [t.section.name for t in tasks] == ["s member 0", "s member 1", "s member 2"]
    for m, t in enumerate(tasks):
        assert t.law.K_s == members.parameters["K_s"][m] and t.options.seed == (3, m + 1)
        # half a year of 10 MGT growing at the member's rate (continuous compounding)
        rate = np.log1p(members.growth[m])
        assert t.options.total_mgt == pytest.approx(10.0 * np.expm1(0.5 * rate) / rate)
        assert t.law.load_exponent == task.law.load_exponent  # not varied


def test_members_run_on_the_drawn_fields_in_turn(task):
    n = 1 + int(round(100.0 / 0.6))  # sleepers of the fixture's section: check the shape
    trk_n = len(task.options.rate_factor or ()) or None
    assert trk_n is None  # the fixture's deterministic task draws its own field
    rng = np.random.default_rng(0)
    fields = np.exp(0.3 * rng.standard_normal((2, 2, n)))  # two draws
    members = sample_members(3, 5, task.law, fields=fields)
    tasks = member_tasks(task, members)
    for m, t in enumerate(tasks):  # member m on draw m modulo 2, its seed not changed
        np.testing.assert_array_equal(np.array(t.options.rate_factor), fields[m % 2])
        assert t.options.seed == task.options.seed

"""A track's life: tamping in the loop, and each vehicle's share of the settlement."""

import dataclasses

import numpy as np
import pytest

from trackdyn.deterioration import LoopOptions, Traffic, load_law, predict
from trackdyn.deterioration.maintenance import Maintenance, MaintenanceOptions
from trackdyn.deterioration.quality import D1Assessment, d1_sd
from trackdyn.deterioration.results import vehicle_shares
from trackdyn.options import RunOptions
from trackdyn.track.quality import longitudinal_level
from trackdyn.track.synthetic import synthetic_track
from trackdyn.vehicle.parameters import load_vehicle

LAW = load_law("power")  # the shipped illustrative parameters


def wagon(axle_t: float, passages: float, speed_kmh: float = 60.0) -> Traffic:
    """The loaded coal wagon's suspension with the body mass for ``axle_t`` t per axle."""
    base = load_vehicle("loaded")
    m1 = 4 * axle_t * 1e3 - 2 * base.m2 - 2 * base.mw  # gross = m1 + 2 m2 + 2 mw
    return Traffic(load_vehicle("loaded", m1=m1), speed_kmh, passages, f"{axle_t:g} t")


@pytest.fixture(scope="module")
def track():
    """400 m of FRA class 5 geometry on varying supports."""
    return synthetic_track(400.0, spectrum="fra5", seed=7)


def _maintenance(track, **kw):
    _, starts, ends = d1_sd(track.geometry, track.extent, 100.0)
    return Maintenance(MaintenanceOptions(**kw), track.supports.position, starts, ends, 1.6)


def test_tamping_follows_the_recovery_relation_and_leaves_the_rest_alone(track):
    m = _maintenance(track, run_out_m=0.0, kept_correlation=0.5)
    g = track.geometry
    before = d1_sd(g, track.extent, 100.0)[0]
    new, held = m.tamp(10.0, np.array([1]), g, track.extent, 100.0)
    x, a, b = g.distance, m.starts[1], m.ends[1]
    inside = (x >= a) & (x <= b)
    for rail in ("left", "right"):  # outside the tamped segment nothing moves
        np.testing.assert_array_equal(new.profile(rail)[~inside], g.profile(rail)[~inside])
    after = d1_sd(new, track.extent, 100.0)[0]
    # the D1 SD after is offset + slope x before (the options' recovery relation); the
    # band filter's reach over the segment ends moves it by a few per cent (measured < 8 %)
    np.testing.assert_allclose(after[:, 1], 0.6 + 0.3 * before[:, 1], rtol=0.1)
    pos = track.supports.position
    np.testing.assert_array_equal(held[0], (pos >= a) & (pos <= b))
    # the track keeps part of its old shape: correlation kept_correlation = 0.5 by
    # construction; one random realisation over 100 m (a few D1 wavelengths) scatters
    core = (x > a + 20.0) & (x < b - 20.0)
    old = longitudinal_level(x, g.left, "D1")[core]
    kept = longitudinal_level(x, new.left, "D1")[core]
    assert 0.2 < np.corrcoef(old, kept)[0, 1] < 0.8
    record = m.done[0]
    assert record.kind == "tamping" and record.segment == 1 and record.mgt == 10.0
    np.testing.assert_allclose(record.sd_after, after[:, 1])
    assert record.lift >= 10e-3  # the general lift is the least


def test_the_machine_runs_out_beyond_the_stretch_smoothly(track):
    """A run-out of 10 m: the tamped profile joins the untamped one without a step, the
    track beyond the run-out does not move, and the run-out's sleepers are packed too."""
    m = _maintenance(track, run_out_m=10.0)
    g = track.geometry
    new, held = m.tamp(10.0, np.array([1]), g, track.extent, 100.0)
    x, a, b = g.distance, m.starts[1] - 10.0, m.ends[1] + 10.0
    reach = (x >= a) & (x <= b)
    for rail in ("left", "right"):
        change = new.profile(rail) - g.profile(rail)
        np.testing.assert_array_equal(change[~reach], 0.0)
        # cosine ramps: the change's slope stays that of the correction (no step at the
        # joints): the largest change between samples is no more than inside the segment
        inside = (x >= m.starts[1]) & (x <= m.ends[1])
        assert np.abs(np.diff(change)).max() <= np.abs(np.diff(change[inside])).max() + 1e-12
    pos = track.supports.position
    np.testing.assert_array_equal(held[0], (pos > a) & (pos < b))


def test_ballast_damage_and_loosening_set_the_rate_factor(track):
    m = _maintenance(track, damage_per_tamping=0.2, max_tampings=2, loosening_mgt=3.0,
                     run_out_m=0.0)  # fmt: skip
    for k in range(3):
        m.tamp(10.0 * (k + 1), np.array([2]), track.geometry, track.extent, 100.0)
    assert [d.kind for d in m.done] == ["tamping", "tamping", "renewal"]
    held = m.sleepers([2])
    # renewal undoes the damage of the two tampings before it: 1, not 1.2^3
    np.testing.assert_allclose(m.damage[held], 1.0)
    np.testing.assert_allclose(m.damage[~held], 1.0)
    # right after, the loosening is 1 + lift / lift_reference; averaged over a step dm it
    # is 1 + (lift / ref) tau / dm (1 - exp(-dm / tau)) (the integral of the decay)
    ratio = m.lift / 40e-3
    np.testing.assert_allclose(m.factor(0.0), 1.0 + ratio)
    dm, tau = 2.0, 3.0
    np.testing.assert_allclose(m.factor(dm), 1.0 + ratio * tau / dm * -np.expm1(-dm / tau))
    m.advance(100.0)
    np.testing.assert_allclose(m.factor(0.0), 1.0, atol=1e-12)


def test_fixed_policy_tamps_every_segment_every_interval(track):
    m = _maintenance(track, policy="fixed", interval_mgt=25.0)
    assert m.next_due(0.0) == 25.0 and m.next_due(25.0) == 50.0
    sd = np.zeros((2, 4))
    np.testing.assert_array_equal(m.due(25.0, sd), np.arange(4))
    assert m.due(30.0, sd).size == 0


def test_threshold_policy_waits_the_minimum_interval_and_takes_neighbours(track):
    m = _maintenance(track, min_interval_mgt=5.0, neighbours=1)
    sd = np.array([[0.5, 0.5, 1.7, 0.5], [0.5, 0.5, 0.5, 0.5]])
    np.testing.assert_array_equal(m.due(1.0, sd), [1, 2, 3])
    m.last[2] = 0.0
    assert m.due(4.0, sd).size == 0  # tamped 4 MGT ago
    np.testing.assert_array_equal(m.due(5.0, sd), [1, 2, 3])


def test_segments_past_the_alert_limit_go_with_one_that_is_due(track):
    m = _maintenance(track, alert_fraction=0.8)  # alert limit 0.8 x 1.6 = 1.28 mm (not the default)
    sd = np.array([[1.3, 0.5, 1.3, 1.3], [0.5, 0.5, 0.5, 0.5]])
    assert m.due(1.0, sd).size == 0  # past the alert limit, but nothing is due
    sd[1, 3] = 1.6
    np.testing.assert_array_equal(m.due(1.0, sd), [2, 3])  # 0 is not next to the stretch
    sd[0, 1] = 1.29
    np.testing.assert_array_equal(m.due(1.0, sd), [0, 1, 2, 3])  # now it is


@pytest.mark.slow
def test_tampings_do_not_depend_on_the_step_size():
    """200 m of FRA class 5 track over 100 MGT, threshold 1.5 mm: the default step limit
    and a quarter of it give the same tampings, at tonnages within 5 % (measured: 1.1 % for
    1 against 0.25 mm, 0.35 % for 0.5 against 0.25 mm; before
    the step was cut at the end of the minimum interval, the alert limit grouped segments
    and a segment counted as due at 0.995 of the threshold rather than 0.98, a segment got
    5 tampings against 7, and tonnages differed by 5 %)."""
    track = synthetic_track(200.0, spectrum="fra5", seed=7)
    runs = []
    for limit in (LoopOptions().max_step_settlement_mm, 0.25):
        o = options(maintenance=MaintenanceOptions(), total_mgt=100.0, snapshot_every_mgt=100.0,
                    rate_cov=0.3, threshold_sd_mm=1.5, segment_length_m=100.0,
                    start="as measured", max_step_settlement_mm=limit)  # fmt: skip
        runs.append(predict(track, [wagon(26.0, 8065.0)], LAW, o))
    coarse, fine = runs
    np.testing.assert_array_equal(coarse.intervention_segment, fine.intervention_segment)
    np.testing.assert_allclose(coarse.intervention_mgt, fine.intervention_mgt, rtol=0.05)


def options(**kw):
    base = {"run": RunOptions(model="4dof"), "total_mgt": 30.0, "snapshot_every_mgt": 10.0,
            "segment_length_m": 60.0, "start": "tamped"}  # fmt: skip
    return LoopOptions(**{**base, **kw})


@pytest.fixture(scope="module")
def short():
    """120 m of FRA class 5 geometry on varying supports."""
    return synthetic_track(120.0, spectrum="fra5", seed=4)


def test_no_traffic_is_never_tamped(short):
    o = options(threshold_sd_mm=0.01, maintenance=MaintenanceOptions())
    ds = predict(short, [wagon(26.0, 0.0)], LAW, o)
    assert ds.sizes["intervention"] == 0
    assert np.all(ds.settlement.values == 0.0)


def _intervals(damage: float, total: float) -> np.ndarray:
    """Intervals between the tampings of the one segment (100 m and the 19 m rest) of
    uniform track with a varying ballast (rate field cov 0.3), threshold 1.5 mm [MGT]. The
    tamping keeps the whole shape (``kept_correlation = 1``: no new random irregularity), so
    cycles may repeat exactly."""
    uniform = synthetic_track(120.0, spectrum=None, stiffness_cov=0.0, gap=0.0, seed=1)
    m = MaintenanceOptions(damage_per_tamping=damage, kept_correlation=1.0)
    o = options(maintenance=m, total_mgt=total, snapshot_every_mgt=total, rate_cov=0.3,
                threshold_sd_mm=1.5, segment_length_m=100.0, start="as measured")  # fmt: skip
    ds = predict(uniform, [wagon(26.0, 8065.0)], LAW, o)
    assert np.all(ds.intervention_segment.values == 0)
    return np.diff(np.r_[0.0, ds.intervention_mgt.values])


def test_without_ballast_damage_the_cycles_repeat():
    """Each tamping leaves the same state (the recovery relation from the same threshold,
    the law's memory of `consolidated_mgt`): the intervals after the first (which starts
    from new ballast) change by at most 4 % from one to the next (measured over 300 MGT:
    30.4, 30.5, 29.9, ... 27.2 MGT, at most 2.7 %; with ballast damage 0.15 they shorten by
    about 18 % each, below). The slow drift (1.2 % a cycle) is the long waves of the
    settlement, which tamping in the D1 band leaves, seen by the band filter at the section's
    far end: the segment reaches it (a 120 m section is one segment of 100 m with the rest;
    before the rest was left out of every segment: 27.9-29.2 MGT)."""
    later = _intervals(0.0, 300.0)[1:]
    assert later.size >= 5
    assert np.all(np.abs(np.diff(later)) <= 0.04 * later[:-1])
    assert later.max() <= 1.15 * later.min()


def test_ballast_damage_shortens_each_interval_until_renewal():
    """Each tamping raises the settlement rate of the ballast (Abadi et al. 2016): each
    interval after the first is shorter than the one before, up to the renewal after
    `max_tampings` (6), which undoes the damage (measured: 24.1, 19.3, 15.3, 12.2, 9.8,
    8.0 MGT, then 27.8 MGT after the renewal)."""
    intervals = _intervals(0.15, 150.0)
    worn = intervals[1:7]  # tampings 2-7: the 7th is the renewal
    assert np.all(np.diff(worn) < 0)
    assert intervals[7] > 2 * intervals[6]  # the renewed ballast lasts as new


@pytest.mark.slow
def test_a_transition_needs_several_times_the_tamping_of_open_track():
    """Embankment 60 kN/mm -> deck 240 kN/mm with approach zones, the shipped parameters of
    each kind, 150 MGT: the segment holding the transition is tamped more than twice as
    often as open track (Dutch transitions are maintained 4-8 times as often, Wang, Markine
    & Liu 2017; measured here: 26 against 7)."""
    from trackdyn.deterioration import Zone
    from trackdyn.track.synthetic import Transition

    deck = Transition(240.0, 30.0, 4.0)
    track = synthetic_track(400.0, spectrum=None, stiffness=60e6, stiffness_cov=0.0, gap=0.0,
                            seed=1, features=(deck,))  # fmt: skip
    zones = [Zone(230.0, 240.0, "approach", load_law("power", kind="approach")),
             Zone(240.0, 270.0, "structure", load_law("power", kind="structure")),
             Zone(270.0, 280.0, "approach", load_law("power", kind="approach"))]  # fmt: skip
    m = MaintenanceOptions()
    o = options(maintenance=m, total_mgt=150.0, snapshot_every_mgt=50.0, rate_cov=0.3,
                threshold_sd_mm=1.5, segment_length_m=100.0, start="as measured",
                max_step_settlement_mm=1.0, max_steps=3000)  # fmt: skip
    ds = predict(track, [wagon(26.0, 8065.0)], LAW, o, zones=zones)
    count = ds.interventions.values
    assert count[2] > 2 * max(count[1], 1)  # 200-300 m holds the deck; 100-200 m open


def test_vehicle_shares_add_up_and_follow_the_equivalent_cycles():
    """Each vehicle's share per passage is its equivalent reference cycles per passage
    (`trackdyn.deterioration.hardening`): from each wagon's own run, ``(e_j / K_s)^(1/β) /
    N_j``. With rail-seat loads proportional to the axle load this is ``2^(α/β)`` for
    twice the axle load (shipped α = 2, β = 0.2: 1024); here the sleepers' own weight in
    the rail-seat load makes the load ratio 1.97 and the share ratio about 750. A wagon
    with no passages has no share; the shares add up to 1."""
    level = synthetic_track(60.0, spectrum=None, stiffness_cov=0.0, gap=0.0, seed=1)
    mix = [wagon(26.0, 1000.0, 20.0), wagon(13.0, 3000.0, 20.0), wagon(20.0, 0.0, 20.0)]
    o = options(total_mgt=2.0, snapshot_every_mgt=1.0, segment_length_m=30.0, rate_cov=0.0)
    shares = vehicle_shares(predict(level, mix, LAW, o))
    assert shares["settlement_share"].sum() == pytest.approx(1.0, rel=1e-9)
    assert shares["settlement_share"].iloc[2] == 0.0
    mid = level.supports.position.size // 2
    per_passage = []
    for t in mix[:2]:
        alone = predict(level, [t], LAW, o)
        e = float(alone.settlement.isel(mgt=-1, rail=0, sleeper=mid))
        cycles = float(alone.load_cycles.isel(rail=0, sleeper=mid))
        per_passage.append((e / LAW.K_s) ** (1 / LAW.beta) / cycles)
    per = shares["settlement_share_per_1000_passages"]
    # shares are over the whole section (ends included), the closed form at mid-track
    assert per.iloc[0] / per.iloc[1] == pytest.approx(per_passage[0] / per_passage[1], rel=0.02)
    assert 0.6 * 2 ** (LAW.load_exponent / LAW.beta) < per.iloc[0] / per.iloc[1] < 1024


def test_a_d1_assessment_set_up_once_equals_one_set_up_for_each_geometry(track):
    """`D1Assessment` keeps the filter and segments of a grid while the geometries stay on it
    (the maintenance's trial steps) and sets them up again on another grid: each D1 SD is
    the one `d1_sd` gives that geometry alone, to the bit (the same operations)."""
    g = track.geometry
    coarse = dataclasses.replace(g, distance=g.distance[::2], left=g.left[::2],
                                 right=g.right[::2])  # fmt: skip
    settled = dataclasses.replace(g, left=g.left + 1e-3 * np.sin(g.distance / 7.0))
    assess = D1Assessment(track.extent, 100.0)
    for geometry in (g, settled, coarse, g):
        got, want = assess(geometry), d1_sd(geometry, track.extent, 100.0)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)
    assert not np.array_equal(assess(g)[0], assess(settled)[0])  # not a stale answer
    assert assess(coarse)[0].shape == assess(g)[0].shape
    assert not np.array_equal(assess(coarse)[0], assess(g)[0])


def test_every_metre_of_a_section_is_in_a_segment():
    """A 500 m section in 200 m segments: the remainder (under half a segment) belongs to
    the last one, so a fault there is assessed and tamped (it was once left out)."""
    trk = synthetic_track(500.0, spectrum="fra5", seed=7)
    sd, starts, ends = d1_sd(trk.geometry, trk.extent, 200.0)
    # from the first to the last point of the geometry's 0.25 m grid inside the extent
    assert starts[0] == pytest.approx(trk.extent[0], abs=0.25)
    assert ends[-1] == pytest.approx(trk.extent[1], abs=0.25)
    np.testing.assert_array_equal(starts[1:], ends[:-1])  # no gap between segments
    assert sd.shape == (2, 2) and 298.0 < ends[-1] - starts[-1] < 300.0  # 200 m + the rest
    m = Maintenance(MaintenanceOptions(run_out_m=0.0), trk.supports.position, starts, ends, 1.6)
    _, held = m.tamp(10.0, np.array([1]), trk.geometry, trk.extent, 200.0)
    pos = trk.supports.position
    np.testing.assert_array_equal(held[0], (pos >= starts[1]) & (pos <= ends[1]))
    # the 98.75 m from 400.5 m to the last grid point, 499.25 m: 164 sleepers at 0.6 m
    assert held[0, pos > 400.5].sum() == 164

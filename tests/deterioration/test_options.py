"""One options model for the loop: the API takes the files' names and units, the SI values
are derived in one place, and the scenario's ``[loop]`` table is that model."""

import pytest

from trackdyn.commands.deteriorate.scenario import DeteriorationScenario, loop_options
from trackdyn.deterioration import LoopOptions, Traffic
from trackdyn.errors import TrackdynInputError
from trackdyn.options import parse
from trackdyn.vehicle.parameters import load_vehicle


def test_the_si_values_are_the_options_with_their_unit_converted():
    o = LoopOptions(max_step_settlement_mm=0.5, segment_length_m=100.0,
                    rate_correlation_length_m=4.0, sleeper_mass_kg=150.0,
                    output_spacing_m=0.05)  # fmt: skip
    assert o.max_step_settlement == 0.5 * 1e-3  # mm -> m, the file's conversion
    assert (o.segment_length, o.rate_correlation_length) == (100.0, 4.0)  # already m
    assert (o.sleeper_mass, o.output_spacing) == (150.0, 0.05)
    si = o.in_si()  # the Dataset's option_<name> attributes
    assert si["max_step_settlement"] == 0.5e-3 and "max_step_settlement_mm" not in si
    assert si["threshold_sd_mm"] == 1.6  # the D1 SD stays in mm, the loop's unit for it
    converted = {"max_step_settlement", "segment_length", "rate_correlation_length",
                 "sleeper_mass", "output_spacing"}  # fmt: skip
    assert converted <= set(si) and not {f"{n}_m" for n in converted} & set(si)
    assert len(si) == len(LoopOptions.model_fields)  # every option, in the model's order
    assert Traffic(load_vehicle("loaded"), 72.0, 1.0).speed == 72.0 / 3.6  # km/h -> m/s


def test_the_loop_table_is_the_options_model():
    """The file's [loop] keys are the `LoopOptions` fields marked so, read by that model
    (same names, same units: the 0.5 mm of a file is 0.5e-3 m in the loop, the file's
    bound refused as pydantic refuses it); the options of other tables are refused there,
    and `loop_options` takes them from their tables by name."""
    assert LoopOptions.loop_table() == ("total_mgt", "max_step_settlement_mm",
                                        "snapshot_every_mgt", "threshold_sd_mm",
                                        "segment_length_m", "max_steps",
                                        "min_step_passages")  # fmt: skip
    data = {"loop": {"max_step_settlement_mm": 0.5, "segment_length_m": 100},
            "settlement": {"rate_correlation_length_m": 4.0, "rate_cov": 0.2},
            "track": {"rail": "54E1", "start": "as surveyed"}}  # fmt: skip
    spec = parse(DeteriorationScenario, data, "s.toml")
    assert isinstance(spec.loop, LoopOptions)
    o = loop_options(spec, (0, 1))
    assert (o.max_step_settlement, o.segment_length_m) == (0.5 * 1e-3, 100.0)
    assert (o.rate_correlation_length_m, o.rate_cov, o.rail, o.start, o.seed) == (
        4.0, 0.2, "54E1", "as surveyed", (0, 1))  # fmt: skip
    # the file's record of the table: its keys only
    assert list(spec.model_dump(mode="json")["loop"]) == list(LoopOptions.loop_table())
    with pytest.raises(TrackdynInputError, match="loop: 'rate_cov' is not a key of \\[loop\\]"):
        parse(DeteriorationScenario, {"loop": {"rate_cov": 0.2}}, "s.toml")
    with pytest.raises(TrackdynInputError, match="loop.max_step_settlement_mm: Input should "):
        parse(DeteriorationScenario, {"loop": {"max_step_settlement_mm": -1}}, "s.toml")

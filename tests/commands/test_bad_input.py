"""Bad input of every command, one row each: refused with exit code 2, one line, no files.

A row gives the command line, the files it reads (text, or bytes where the encoding is
the point) and a fragment of the expected message.
In the files and arguments ``{track}`` stands for a folder holding a 300 m section
(``g.csv``, ``s.csv``), that geometry with 5 m of NaN from line 12 (``gnan.csv``), supports
covering only its first 50 m (``s50.csv``), every 17th sleeper only, 10.2 m apart
(``s10.csv``), and all but three sleepers in a row, a 2.4 m gap (``sgap.csv``); and the
shipped calibration's 200 m surveys 1 and 2 (``c1.csv``, ``c2.csv``) and supports
(``cs.csv``), the first survey's first 150 m and 40 m (``c150.csv``, ``c40.csv``) and moved
by 150 m (``cmoved.csv``), the supports' first 100 m (``cs100.csv``). Each case
runs in a folder of its own, with ``--out out`` unless the row gives ``--out``; afterwards
that folder holds the row's files and nothing else.
"""

import errno
import os
import shutil

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from typer.testing import CliRunner

from trackdyn.cli import app
from trackdyn.commands.examples import example_file
from trackdyn.deterioration.law_files import DEFAULT_FILE
from trackdyn.io import write_geometry, write_supports
from trackdyn.track.synthetic import synthetic_track

runner = CliRunner()

WAGON_K1_IN_N = 'base = "loaded"\n[k1]\nvalue = 4.0\nunit = "N/m"\nsource = "typed"\n'
TRACK = '[track]\ngeometry = "{track}/g.csv"\nsupports = "{track}/s50.csv"\n'
NAN_TRACK = '[track]\ngeometry = "{track}/gnan.csv"\nsupports = "{track}/s.csv"\n'

GEOMETRY_KM_HOLDING_M = "distance_km,left_mm,right_mm\n" + "".join(
    f"{0.25 * i:g},0,0\n" for i in range(1201)
)  # 300 m of samples 0.25 m apart, the column saying km

RATE_FIELD = '[settlement]\nrate_field = "f.csv"\n[loop]\ntotal_mgt = 0.1\n'


def rate_rows(factor, upto_m: float) -> str:
    """A rate-field file, both rails every 0.6 m from 0 to ``upto_m``."""
    rows = (f"{0.6 * i:.1f},{rail},{factor},0.1\n" for i in range(int(upto_m / 0.6) + 1)
            for rail in ("left", "right"))  # fmt: skip
    return "distance_m,rail,factor,standard_error\n" + "".join(rows)


CALIBRATION = (
    '[track]\nsupports = "s.csv"\n[[survey]]\ngeometry = "a.csv"\nmgt = 0\n'
    '[[survey]]\ngeometry = "b.csv"\nmgt = 1\n[fit]\nparameters = ["K_s"]\n'
)

MEASURED = '[track]\ngeometry = "{track}/g.csv"\nsupports = "k.csv"\nsupports_kind = "measured"\n'
"""A run on a measured stiffness ``k.csv`` along the 300 m section."""

CASES = [
    # (command line, files {name: text}, message fragment)
    (  # a measured stiffness of 0.1 kN/mm: metres per meganewton taken for kN/mm?
        ["run", "bad.toml"],
        {
            "bad.toml": MEASURED + "stiffness_load_kN = 100\n",
            "k.csv": "distance_m,rail,stiffness_kN_per_mm\n0,left,80\n300,left,0.1\n"
            "0,right,80\n300,right,80\n",
        },
        "k.csv: line 3: the left rail's stiffness is 0.1 kN/mm, outside the plausible 1 to",
    ),
    (
        ["run", "bad.toml"],
        {
            "bad.toml": MEASURED + "stiffness_load_kN = 100\n",
            "k.csv": "distance_m,rail,stiffness_kN_per_mm\n0,left,80\n300,left,80\n"
            "0,right,80\n0,right,80\n",
        },
        "k.csv: line 5: the right rail's distances are not increasing",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": MEASURED},
        "supports_kind = 'measured' needs stiffness_load_kN",
    ),
    (
        ["run", "bad.toml"],
        {
            "bad.toml": MEASURED + "stiffness_load_kN = 400\n",
            "k.csv": "distance_m,rail,stiffness_kN_per_mm\n0,left,80\n0,right,80\n",
        },
        "stiffness_load_kN = 400 kN is outside the example curve shape's loads (up to 250 kN)",
    ),
    (
        ["run", "bad.toml"],
        {
            "bad.toml": '[track]\ngeometry = "{track}/g.csv"\nsupports = "{track}/s.csv"\n'
            "stiffness_load_kN = 100\n"
        },
        "stiffness_load_kN: for supports_kind = 'measured'",
    ),
    (
        ["run", "bad.toml"],
        {
            "bad.toml": '[track]\ngeometry = "{track}/g.csv"\nsupports = "{track}/s.csv"\n'
            'supports_kind = "measured"\nstiffness_load_kN = 100\n'
        },
        "s.csv: supports_kind = 'measured' reads a column stiffness_kN_per_mm",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": '[maintenance]\npolicy = "fixed"\n'},
        "maintenance policy 'fixed' needs interval_mgt",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[loop]\ntotal_mgt = 5\n[maintenance]\nhorizon_years = 3\nannual_mgt = 10\n"},
        "give the horizon as [loop] total_mgt or as [maintenance] horizon_years",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[maintenance]\nhorizon_years = 3\n"},
        "give horizon_years and annual_mgt together",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[maintenance]\nrecovery_slope = 1.5\n"},
        "recovery_slope",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[settlement]\noverrides = { K_s = 0.5 }\n[loop]\ntotal_mgt = 0.1\n"},
        "K_s = 0.5 m is outside the plausible 1e-05 to 0.01 m",
    ),
    (
        ["run", "bad.toml"],
        {
            "bad.toml": '[track]\ngeometry = "gkm.csv"\nsupports = "{track}/s.csv"\n',
            "gkm.csv": GEOMETRY_KM_HOLDING_M,
        },
        "gkm.csv: the profile samples are 250 m apart by column 'distance_km'",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[settlement]\noverrides = { K_s = -0.5 }\n[loop]\ntotal_mgt = 0.1\n"},
        "[settlement] overrides of [power] K_s = -0.5 m is outside the plausible",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[settlement]\nrate_cov = 100\n[loop]\ntotal_mgt = 0.1\n"},
        "rate_cov is 100.0, outside the plausible 0 to 3",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": "[loop]\nsegment_length_m = 1e6\ntotal_mgt = 0.1\n"},
        "segment_length_m = 1e+06 m is longer than the track",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nspeed_kmh = 1e6\n"},
        "run.speed_kmh: Input should be less than or equal to 400",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[run]\nspeed_kmh = "60"\n'},
        "run.speed_kmh: Input should be a valid number",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\ndt_s = 0.1\n"},
        "bad.toml: time step dt_s = 0.1 s is beyond the stability limit",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { muu = 0.3 }\n"},
        "unknown vehicle parameter 'muu'",
    ),
    (["run", "bad.toml"], {"bad.toml": "[vehicle]\noverrides = { mu = 0.9 }\n"}, "locks the wedge"),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { k1 = -5.0 }\n"},
        "k1 is -5 N/m, outside the plausible",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[vehicle]\npreset = "tanker"\n'},
        "unknown vehicle preset 'tanker'",
    ),
    (["run", "bad.toml"], {"bad.toml": "[run]\nspeed_kmh = 0\n"}, "run.speed_kmh"),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nspeed_kmh = 60\ndt_s = 0.01\n"},
        "beyond the stability limit",
    ),
    (["run", "bad.toml"], {"bad.toml": '[run]\nmodel = "3dof"\n'}, "run.model"),
    (["run", "bad.toml"], {"bad.toml": "[run]\nspeeed = 3\n"}, "unknown key 'run.speeed'"),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[track]\ngeometry = "missing.csv"\nsupports = "missing.csv"\n'},
        "missing.csv: no such file",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[track]\ngeometry = "missing.csv"\n'},
        "give both a geometry and a supports file",
    ),
    (["run", "bad.toml"], {"bad.toml": "not toml ["}, "not valid TOML"),
    (
        ["run", "bad.toml"],
        {"bad.toml": "# Prüfstrecke\n[run]\nspeed_kmh = 60\n".encode("latin-1")},
        "bad.toml: line 1: byte 0xfc is not UTF-8 (saved as Latin-1",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nspeed_kmh = 60\n".encode("utf-16")},
        "bad.toml: saved as UTF-16 (or not text); save it as UTF-8",
    ),
    (
        ["track", "--geometry", "g.csv", "--supports", "{track}/s.csv"],
        {"g.csv": "distance_m;left_mm;right_mm\n0;1,5;2,0\n0,25;1,5;2,0\n"},
        "g.csv: columns separated by ';' (a spreadsheet's CSV with decimal commas?)",
    ),
    (["track", "--wheel-load-kN", "0"], {}, "--wheel-load-kN is 0 kN, outside the plausible"),
    (["track", "--wheel-load-kN", "-3"], {}, "--wheel-load-kN is -3 kN, outside the plausible"),
    (["track", "--rail", "UIC99"], {}, "unknown rail section"),
    (["track", "--wheel-load-kN", "400"], {}, "outside the measured curve"),
    (["track", "--delta", "1.5"], {}, "delta must be in (0, 1)"),
    (
        ["track", "--geometry", "geometry.csv", "--supports", "{track}/s.csv"],
        {"geometry.csv": "distance_m,left_mm,right_mm\n0,1,1\n0.25,nan,1\n"},
        "geometry.csv: column 'left_mm' is empty, NaN, infinite or not a number at line 3",
    ),
    (
        ["study", "speed.toml"],
        {"speed.toml": 'kind = "speed"\n[speed]\nspeeds_kmh = []\n'},
        "speed.toml: speed.speeds_kmh: List should have at least 1",
    ),
    (
        ["study", "--scheduler", "garbage"],
        {},
        "--scheduler 'garbage' is not an address like tcp://HOST:PORT",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { k1 = 4.0 }\n"},
        "bad.toml: vehicle parameter k1 is 4 N/m, outside the plausible 100000 to 1e+09 N/m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { m1 = 94.4 }\n"},
        "vehicle parameter m1 is 94.4 kg, outside the plausible 1000 to 1e+06 kg",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[vehicle]\noverrides = { kp = 1e15 }\n"},
        "vehicle parameter kp is 1e+15 N/m, outside the plausible 100000 to 1e+12 N/m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[vehicle]\noverrides = { mu = "0.3" }\n'},
        "bad.toml: vehicle.overrides.mu: Input should be a valid number",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[vehicle]\nfile = "wagon.toml"\n', "wagon.toml": WAGON_K1_IN_N},
        "wagon.toml: vehicle parameter k1 is 4 N/m, outside the plausible",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": '[vehicle]\npreset = "empty"\nfile = "wagon.toml"\n'},
        "bad.toml: vehicle: give a preset or a file, not both",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\ndt_s = 1e-9\n"},
        "bad.toml: time step dt_s = 1e-09 s gives",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nend_m = 5000.0\n"},
        "bad.toml: end_m = 5000 m is outside the track, 0.3 to 999.9 m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nstart_m = -500.0\n"},
        "bad.toml: start_m = -500 m is outside the track, 0.3 to 999.9 m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": TRACK},
        "s50.csv: supports cover 0.3 to 49.5 m, the geometry 0 to 300 m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": TRACK.replace("s50.csv", "s10.csv")},
        "s10.csv: sleepers at 0.3 and 10.5 m are 10.2 m apart, more than the plausible 3 m",
    ),
    (
        ["track", "--geometry", "{track}/g.csv", "--supports", "{track}/s10.csv"],
        {},
        "s10.csv: sleepers at 0.3 and 10.5 m are 10.2 m apart, more than the plausible 3 m",
    ),
    (["run", "--out", ""], {}, "--out is empty"),
    (
        ["study", "bad.toml"],
        {"bad.toml": "[run]\nspeed_kmh = 60\n"},
        "bad.toml: no kind, matrix, sensitivity, speed: a run scenario",
    ),
    (
        ["study", "bad.toml"],
        {"bad.toml": 'kind = "speed"\n' + NAN_TRACK},
        "gnan.csv: lines 11-32: a gap of 5.25 m in the geometry (2.25 to 7.5 m), longer than",
    ),
    (["study", "--workers", "100000"], {}, "--workers 100000 is outside the plausible 1 to"),
    (
        ["track", "--wheel-load-kN", "0.001"],
        {},
        "--wheel-load-kN is 0.001 kN, outside the plausible 1 to 500 kN",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": RATE_FIELD, "f.csv": rate_rows(1.0, 100.0)},  # the example is 1 km
        "the field must cover the track",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": RATE_FIELD, "f.csv": rate_rows("none", 1100.0)},
        "f.csv: line 2: needs distance_m a number, rail left or right and factor in (0, 100]",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": RATE_FIELD.replace("[loop]", "seed = 3\n[loop]")},
        "settlement: give rate_field or rate_cov and seed, not both",
    ),
    (
        ["calibrate", "bad.toml"],
        {"bad.toml": CALIBRATION + "[settlement]\nrate_cov = 0\n"},
        "settlement.rate_cov: a calibration estimates the rate field or takes it uniform",
    ),
]


SURVEYED = (
    '[track]\nsupports = "{track}/cs.csv"\n[[survey]]\ngeometry = "{track}/c1.csv"\nmgt = 0\n'
    '[[survey]]\ngeometry = "{track}/c2.csv"\nmgt = 2\n[loop]\nsegment_length_m = 100\n'
    '[fit]\nparameters = ["K_s"]\n'
)  # the shipped calibration's surveys 1-2 and supports, 200 m

CASES += [
    # calibrations: surveys that fit to nothing or do not line up, tables not used
    (
        ["calibrate", "bad.toml"],
        {"bad.toml": SURVEYED.replace("c2.csv", "c1.csv")},
        "survey 2 ({track}/c1.csv) at 2 MGT: its D1-band change from survey 1 ({track}/c1.csv) "
        "at 0 MGT is 0 mm RMS, not above 2 x its measurement noise",
    ),
    (
        ["calibrate", "bad.toml"],
        {"bad.toml": SURVEYED + "[maintenance]\n"},
        "bad.toml: [maintenance]: not used by a calibration",
    ),
    (
        ["calibrate", "bad.toml"],
        {"bad.toml": SURVEYED + "max_shift_m = 1e6\n"},
        "bad.toml: fit.max_shift_m: Input should be less than or equal to 100",
    ),
    (
        ["calibrate", "bad.toml"],
        {"bad.toml": SURVEYED.replace("c1.csv", "c150.csv") + "max_shift_m = 100\n"},
        "fit.max_shift_m = 100 m is beyond 75 m, 0.5 of the first survey's 150 m",
    ),
    (
        ["calibrate", "bad.toml"],
        {"bad.toml": SURVEYED.replace("c2.csv", "cmoved.csv")},
        "cmoved.csv: covers 150-350 m and overlaps {track}/c1.csv (0-200 m) by less than half",
    ),
    (
        ["calibrate", "bad.toml"],
        {"bad.toml": SURVEYED.replace("c2.csv", "c40.csv")},
        "survey 2 ({track}/c40.csv): covers 0-40 m (40 m); the fit needs 75 m",  # 2 x 25 + 25
    ),
    (
        ["calibrate", "bad.toml"],
        {"bad.toml": SURVEYED.replace("cs.csv", "cs100.csv")},
        "cs100.csv: supports cover 0.3 to 99.9 m, the geometry 0 to 200 m ({track}/c1.csv)",
    ),
]

SECTION = '[track]\ngeometry = "{track}/g.csv"\nsupports = "{track}/s.csv"\n'
SHORT = SECTION + "[loop]\ntotal_mgt = 0.1\n"
MAINTAINED = SHORT + "[maintenance]\n"
SECTIONS = '[track]\nsections = "l.csv"\n[loop]\ntotal_mgt = 0.1\n'


SOFT_KIND = (
    DEFAULT_FILE.read_text() + '[power.soft]\nK_s = { value = 0.2, unit = "m", source = "x" }\n'
)
"""The shipped parameter file with a zone kind of the user's own, its K_s typed in m."""


def sections_list(header: str, name: str = "a") -> str:
    """A sections list of one section, the 300 m one, under ``header``."""
    return f"{header}\n{name},{{track}}/g.csv,{{track}}/s.csv\n"


CASES += [
    # maintenance values: numbers, finite, within their plausible ranges (issue 41)
    *(
        (["deteriorate", "bad.toml"], {"bad.toml": MAINTAINED + line}, message)
        for line, message in [
            ("consolidated_mgt = inf", "maintenance.consolidated_mgt: Input should be a finite"),
            ("damage_per_tamping = inf", "maintenance.damage_per_tamping: Input should be a fin"),
            ("general_lift_mm = inf", "maintenance.general_lift_mm: Input should be a finite"),
            ("recovery_offset_mm = inf", "maintenance.recovery_offset_mm: Input should be a fin"),
            ("loosening_mgt = inf", "maintenance.loosening_mgt: Input should be a finite"),
            ("run_out_m = inf", "maintenance.run_out_m: Input should be a finite"),
            ('interval_mgt = "5"', "maintenance.interval_mgt: Input should be a valid number"),
            ('max_tampings = "6"', "maintenance.max_tampings: Input should be a valid integer"),
            ("damage_per_tamping = 1e6", "damage_per_tamping: Input should be less than or eq"),
            ("lift_reference_mm = 1e-9", "lift_reference_mm: Input should be greater than or"),
            ("recovery_offset_mm = 1e6", "recovery_offset_mm: Input should be less than or eq"),
            ("general_lift_mm = 1e6", "general_lift_mm: Input should be less than or equal"),
            ("run_out_m = 1e9", "run_out_m: Input should be less than or equal to 100"),
            ("min_interval_mgt = 1e6", "min_interval_mgt: Input should be less than or equal"),
            ('policy = "fixed"\ninterval_mgt = 1e-6', "interval_mgt: Input should be greater"),
            ('policy = "fixed"\ninterval_mgt = 100', "interval_mgt = 100 MGT is beyond the hor"),
        ]
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTION + "[loop]\nthreshold_sd_mm = 0.3\n[maintenance]\n"},
        "bad.toml: [loop] threshold_sd_mm = 0.3 mm is not above [maintenance] recovery_offset",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTION + "[maintenance]\nhorizon_years = inf\nannual_mgt = 10\n"},
        "maintenance.horizon_years: Input should be a finite number",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTION + '[maintenance]\nhorizon_years = "3"\nannual_mgt = 10\n'},
        "maintenance.horizon_years: Input should be a valid number",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTION + "[maintenance]\nhorizon_years = 1e6\nannual_mgt = 1e3\n"},
        "maintenance.horizon_years: Input should be less than or equal to 200",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTION + "[maintenance]\nhorizon_years = 100\nannual_mgt = 200\n"},
        "horizon_years x annual_mgt is 20000 MGT, outside the plausible 0 to 10000 MGT",
    ),
    # the loop: a horizon, snapshots and steps that would hang or fill the memory
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTION + "[loop]\ntotal_mgt = 1e9\nsnapshot_every_mgt = 1e8\n"},
        "loop.total_mgt: Input should be less than or equal to 10000",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTION + "[loop]\ntotal_mgt = 2\nsnapshot_every_mgt = 1e-7\n"},
        "and 2e+07 snapshots (total_mgt = 2, snapshot_every_mgt = 1e-07) needs about",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SHORT.replace("total_mgt", "max_step_settlement_mm = 1e-9\ntotal_mgt")},
        "loop.max_step_settlement_mm: Input should be greater than or equal to 0.01",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SHORT.replace("total_mgt", "segment_length_m = 0.1\ntotal_mgt")},
        "loop.segment_length_m: Input should be greater than or equal to 25",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SHORT.replace("total_mgt", "min_step_passages = 1e12\ntotal_mgt")},
        "loop.min_step_passages: Input should be less than or equal to 1000000",
    ),
    # rate fields: the correlation length, a zone's own, a rail seat given twice
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SHORT + "[settlement]\nrate_correlation_length_m = 1e9\n"},
        "rate_correlation_length_m is 1000000000.0 m, outside the plausible 0 to 1000 m",
    ),
    (
        ["deteriorate", "bad.toml"],
        {
            "bad.toml": SHORT.replace("[loop]", 'zones = "z.csv"\n[loop]'),
            "z.csv": "start_m,end_m,kind,rate_cov,rate_correlation_length_m\n0,50,open,0.3,1e9\n",
        },
        "z.csv: line 2: rate_correlation_length_m is 1000000000.0 m, outside the plausible",
    ),
    (
        ["deteriorate", "bad.toml"],
        {
            "bad.toml": SHORT.replace("[loop]", 'zones = "z.csv"\n[loop]'),
            "z.csv": "start_m,end_m,kind,rate_cov\n0,50,open,100\n",
        },
        "z.csv: line 2: rate_cov is 100.0, outside the plausible 0 to 3",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": RATE_FIELD, "f.csv": rate_rows(1.0, 1100.0) + "30.6,left,5.0,0.1\n"},
        "f.csv: lines 104 and 3670 both give the left rail at 30.6 m",  # 1834 seats x 2, +1
    ),
    # zones: a kind of the user's own typed in m, not mm; a range backwards
    (
        ["deteriorate", "bad.toml"],
        {
            "bad.toml": SHORT.replace(
                "[loop]", 'zones = "z.csv"\n[settlement]\nfile = "p.toml"\n[loop]'
            ),  # fmt: skip
            "z.csv": "start_m,end_m,kind\n100,150,soft\n",
            "p.toml": SOFT_KIND,
        },
        "p.toml: [power.soft] K_s = 0.2 m is outside the plausible 1e-05 to "
        "0.01 m (min and max of [power] there)",  # the shipped 0.01-10 mm; after "z.csv: line 2: "
    ),
    (
        ["deteriorate", "bad.toml"],
        {
            "bad.toml": SHORT.replace("[loop]", 'zones = "z.csv"\n[loop]'),
            "z.csv": "start_m,end_m,kind\n200,100,open\n",
        },
        "z.csv: line 2: end_m 100 m is not beyond start_m 200 m",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": "[run]\nstart_m = 200\nend_m = 100\n"},
        "bad.toml: run: end_m = 100 m is not beyond start_m = 200 m",
    ),
    # sections lists: a zones column misnamed, an extra column, a name of dots
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTIONS, "l.csv": sections_list("name,geometry,supports,zone") + ","},
        "l.csv: unknown column 'zone'; the columns are name, geometry, supports, zones",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTIONS, "l.csv": sections_list("name,geometry,supports,note") + ",x"},
        "l.csv: unknown column 'note'",
    ),
    (
        ["deteriorate", "bad.toml"],
        {"bad.toml": SECTIONS, "l.csv": sections_list("name,geometry,supports", "..")},
        "l.csv: line 2: section name '..' is empty, repeated or not made of letters",
    ),
    # interventions: a settlement-rate range beyond the 300 m section (its sleepers 0.3-299.7 m)
    (
        ["study", "study.toml"],
        {
            "study.toml": 'kind = "interventions"\nscenario = "m.toml"\n[[alternative]]\n'
            'name = "x"\nsettlement_scale = [{ from_m = 5000, to_m = 6000, factor = 0.5 }]\n',
            "m.toml": MAINTAINED,
        },
        "study.toml: alternative 'x': settlement_scale 5000-6000 m is outside section "
        "g's supports (0.3-299.7 m)",
    ),
    # runs: stored steps, a gap the discrete track does not span
    (
        ["run", "bad.toml"],
        {"bad.toml": TRACK.replace("s50.csv", "sgap.csv") + '[run]\ntrack = "discrete"\n'},
        "sgap.csv: sleepers at 119.7 and 122.1 m are 2.4 m apart, more than the discrete",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": SECTION + "[run]\nstore_every = 1000000000\n"},
        "store_every = 1000000000 is not less than the run's",
    ),
    (
        ["run", "bad.toml"],
        {"bad.toml": SECTION + '[run]\nstore_every = 1000000000\ntrack = "discrete"\n'},
        "store_every = 1000000000 is not less than the run's",
    ),
]


@pytest.fixture(scope="module")
def track_folder(tmp_path_factory):
    """A 300 m section, its geometry with 5 m of NaN, supports covering 50 m or 10 m apart;
    the shipped calibration's surveys 1-2 and supports, the first survey cut to 150 m and to
    40 m and moved by 150 m, the supports cut to 100 m."""
    folder = tmp_path_factory.mktemp("track")
    trk = synthetic_track(300.0, spectrum="fra5", seed=3)
    write_geometry(trk.geometry, folder / "g.csv")
    write_supports(trk.supports, folder / "s.csv")
    geometry = pd.read_csv(folder / "g.csv")
    geometry.loc[10:29, "left_mm"] = float("nan")  # 21 steps of 0.25 m: longer than 2 m
    geometry.to_csv(folder / "gnan.csv", index=False)
    rows = pd.read_csv(folder / "s.csv")
    rows[rows["distance_m"] < 50].to_csv(folder / "s50.csv", index=False)
    every_17th = rows["distance_m"].isin(rows["distance_m"].unique()[::17])
    rows[every_17th].to_csv(folder / "s10.csv", index=False)
    three = rows["distance_m"].isin(rows["distance_m"].unique()[200:203])  # 120.3-121.5 m
    rows[~three].to_csv(folder / "sgap.csv", index=False)
    for name, target in (("c1", "survey_1"), ("c2", "survey_2"), ("cs", "supports")):
        shutil.copy(example_file("calibration", f"{target}.csv"), folder / f"{name}.csv")
    survey = pd.read_csv(folder / "c1.csv")  # 0-200 m
    survey[survey["distance_m"] <= 150].to_csv(folder / "c150.csv", index=False)
    survey[survey["distance_m"] <= 40].to_csv(folder / "c40.csv", index=False)
    survey.assign(distance_m=survey["distance_m"] + 150).to_csv(folder / "cmoved.csv", index=False)
    supports = pd.read_csv(folder / "cs.csv")
    supports[supports["distance_m"] < 100].to_csv(folder / "cs100.csv", index=False)
    return folder


@pytest.mark.parametrize(("args", "files", "message"), CASES)
def test_bad_input_is_refused(tmp_path, monkeypatch, track_folder, args, files, message):
    monkeypatch.chdir(tmp_path)
    folder = track_folder.as_posix()
    for name, text in files.items():
        if isinstance(text, bytes):
            (tmp_path / name).write_bytes(text)
        else:
            (tmp_path / name).write_text(text.replace("{track}", folder))
    args = [a.replace("{track}", folder) for a in args]
    if "--out" not in args:
        args += ["--out", "out"]
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert message.replace("{track}", folder) in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1  # one line, no traceback
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(files)  # nothing written


def test_a_scenario_with_a_byte_order_mark_is_read(tmp_path, monkeypatch):
    """A TOML saved by Windows Notepad starts with a UTF-8 byte-order mark (before: "not
    valid TOML"); it is refused or accepted as the same file without the mark."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bom.toml").write_bytes(b"\xef\xbb\xbf[run]\nspeeed = 3\n")
    result = runner.invoke(app, ["run", "bom.toml", "--out", "out"])
    assert result.exit_code == 2
    assert "bom.toml: unknown key 'run.speeed'" in result.stderr  # read past the mark


TRACK_ARGS = ["track", "--geometry", "{track}/g.csv", "--supports", "{track}/s.csv"]


def _full_disk_errors(monkeypatch, how: str):
    """Make every netCDF write fail as on a full file system: with ENOSPC, or as netCDF-4
    reports it (``NetCDF: HDF error``, no errno) with no space left there."""

    def fail(self, *args, **kwargs):
        if how == "errno":
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        raise RuntimeError("NetCDF: HDF error")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", fail)
    if how == "hdf":
        full = shutil.disk_usage(".")._replace(free=0)
        monkeypatch.setattr(shutil, "disk_usage", lambda path: full)


@pytest.mark.parametrize("how", ["errno", "hdf"])
def test_a_full_disk_is_one_line_and_keeps_the_previous_outputs(
    tmp_path, monkeypatch, track_folder, how
):
    """The output folder's file system fills up while the outputs are written (before: a
    77-line ``RuntimeError: NetCDF: HDF error``): one line, and the previous run's files
    as they were."""
    monkeypatch.chdir(tmp_path)
    args = [a.replace("{track}", track_folder.as_posix()) for a in TRACK_ARGS]
    assert runner.invoke(app, [*args, "--out", "out"]).exit_code == 0
    before = {p.name: p.read_bytes() for p in (tmp_path / "out").iterdir()}
    _full_disk_errors(monkeypatch, how)
    for out in ("out", "new"):
        result = runner.invoke(app, [*args, "--out", out])
        assert result.exit_code == 2, result.output
        assert result.stderr.startswith(f"error: no space left on {out}: nothing written")
        assert len(result.stderr.strip().splitlines()) == 1
    assert {p.name: p.read_bytes() for p in (tmp_path / "out").iterdir()} == before
    assert not (tmp_path / "new").exists()


UNREADABLE = [
    # (command line, the file made unreadable, files {name: text})
    (["run", "bad.toml"], "bad.toml", {"bad.toml": "[run]\nspeed_kmh = 60\n"}),
    (["run", "bad.toml"], "g.csv", {"bad.toml": '[track]\ngeometry = "g.csv"\n'
                                                'supports = "{track}/s.csv"\n'}),
    (["track", "--geometry", "g.csv", "--supports", "{track}/s.csv"], "g.csv", {}),
    (["deteriorate", "bad.toml"], "z.csv", {"bad.toml": '[track]\ngeometry = "g.csv"\n'
                                            'supports = "{track}/s.csv"\nzones = "z.csv"\n',
                                            "z.csv": "start_m,end_m,kind\n0,50,structure\n"}),
    (["deteriorate", "bad.toml"], "l.csv", {"bad.toml": '[track]\nsections = "l.csv"\n',
                                            "l.csv": "name,geometry,supports\na,g.csv,s.csv\n"}),
]  # fmt: skip


@pytest.mark.parametrize(("args", "unreadable", "files"), UNREADABLE)
def test_an_unreadable_file_is_named(tmp_path, monkeypatch, track_folder, args, unreadable, files):
    """A file without read permission (before: a 68-line PermissionError, or click's
    four-line usage error for a file given on the command line): one line naming it."""
    monkeypatch.chdir(tmp_path)
    folder = track_folder.as_posix()
    shutil.copy(track_folder / "g.csv", tmp_path / "g.csv")
    for name, text in files.items():
        (tmp_path / name).write_text(text.replace("{track}", folder))
    (tmp_path / unreadable).chmod(0)
    if os.access(tmp_path / unreadable, os.R_OK):
        pytest.skip("files without read permission are readable here (root)")
    args = [a.replace("{track}", folder) for a in args]
    result = runner.invoke(app, [*args, "--out", "out"])
    assert result.exit_code == 2, result.output
    assert f"{unreadable}: cannot read the file (Permission denied)" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_valid_input_once_refused_is_taken(tmp_path, track_folder):
    """A section named ``NA`` (pandas' default reads it as NaN), rate-field rails written
    ``Left``/``Right`` and a 300 m segment on a 300 m section (whose sleepers, 0.6 m apart,
    span 299.4 m) are accepted."""
    from trackdyn.commands.deteriorate.sections import read_sections
    from trackdyn.deterioration.ballast import read_rate_field
    from trackdyn.deterioration.loop import _start_state
    from trackdyn.deterioration.options import LoopOptions
    from trackdyn.io import read_geometry, read_supports
    from trackdyn.track.track import Track

    listed = tmp_path / "l.csv"
    listed.write_text(sections_list("name,geometry,supports", "NA").format(track=track_folder))
    assert [s.name for s in read_sections(listed)] == ["NA"]
    track = Track(read_geometry(track_folder / "g.csv"), read_supports(track_folder / "s.csv"))
    rows = [f"{x:g},{rail},2.0\n" for x in track.supports.position for rail in ("Left", "Right")]
    field = tmp_path / "f.csv"
    field.write_text("distance_m,rail,factor\n" + "".join(rows))
    assert np.all(read_rate_field(field, track.supports.position) == 2.0)
    _, starts, ends = _start_state(track, LoopOptions(segment_length_m=300.0))
    assert (starts.size, ends.size) == (1, 1)


def test_a_run_beyond_the_memory_is_refused_before_it_starts(tmp_path, monkeypatch):
    """A run whose stored arrays would not fit (a 200 km 11-DOF run: 1.2e7 stored steps, 14
    GB by `RUN_MEMORY_FACTOR`) is refused up front, naming what it needs; the budget is set
    here to 1 MB, under what the 1 km example's 6.4e4 stored steps need (73 MB)."""
    from trackdyn import limits

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(limits, "memory_budget", lambda: 1e6)
    result = runner.invoke(app, ["run", "--out", "out"])
    assert result.exit_code == 2, result.output
    assert "a run over 989.2 m (6.39e+04 stored steps of 11dof) needs about 0.0729 GB" in (
        result.stderr
    )
    assert len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()

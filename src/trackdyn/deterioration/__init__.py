"""Track deterioration over accumulated traffic: dynamic loads, settlement, new geometry.

``predict`` runs the loop on one section (`trackdyn.deterioration.loop.SectionLoop`, its
phases, driven by `trackdyn.deterioration.driver.step_together`) with the `LoopOptions`
and `Traffic` of `trackdyn.deterioration.options`; ``load_law`` reads a settlement law and
its parameters; `trackdyn.deterioration.runs` runs many sections (or laws) through Dask; the
start states (tamped, as measured, as surveyed) are `trackdyn.deterioration.starts`.
"""

from trackdyn.deterioration.law_files import load_law
from trackdyn.deterioration.loop import predict
from trackdyn.deterioration.options import LoopOptions, Traffic
from trackdyn.deterioration.settlement import (
    LAWS,
    PowerLaw,
    SatoLaw,
    SettlementLaw,
    ShentonLaw,
    VarandasLaw,
)
from trackdyn.deterioration.zones import RateField, Zone

__all__ = [
    "LAWS",
    "LoopOptions",
    "PowerLaw",
    "SatoLaw",
    "SettlementLaw",
    "ShentonLaw",
    "RateField",
    "Traffic",
    "VarandasLaw",
    "Zone",
    "load_law",
    "predict",
]

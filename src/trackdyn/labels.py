"""Column names in words with their units, for the headers of tables and the axes of
figures: ``dyn_load_max_kN`` is "ΔP max [kN]"."""

from __future__ import annotations

# Units shown for column-name suffixes (longest first, so ``_kN_per_mm`` wins over ``_mm``).
HEADER_UNITS = {
    "_m_per_100_mgt": "m/100 MGT",
    "_kN_per_mm": "kN/mm",
    "_m_per_s2": "m/s²",
    "_m_per_s": "m/s",
    "_kmh": "km/h",
    "_mgt": "MGT",
    "_kN": "kN",
    "_mm": "mm",
    "_Hz": "Hz",
    "_m": "m",
}
# Short names of known quantities (column name without its unit suffix).
SHORT_NAMES = {
    "dyn_load_max": "ΔP max",
    "dyn_load_min": "ΔP min",
    "dyn_load_sd": "ΔP SD",
    "dyn_load_sd_mean": "ΔP SD, contact mean",
    "dominant_frequency": "f dom.",
    "secondary_max": "sec. max",
    "body_bounce_acc_rms": "bounce RMS",
    "k2_mean": "k2 mean",
    "k2_min": "k2 min",
    "k2_max": "k2 max",
    "ys_mean": "ys mean",
    "d1_sd_max": "D1 SD max",
    "d2_sd_max": "D2 SD max",
    "mgt": "MGT",
    "error_start": "error at the start",
    "life_cycle_cost": "life-cycle cost",
    "d1_sd_horizon_max": "D1 SD at the horizon, max",
    "d1_sd_horizon_mean": "D1 SD at the horizon, mean",
    "since_tamping_mean": "since tamping, mean",
}
# Notes printed under a table whose headers use the symbol.
NOTES = {"ΔP": "ΔP: dynamic wheel load (wheel load - static wheel load)"}


def header(column: str, currency: str | None = None) -> str:
    """Table header of a column: its quantity in words, then its unit in brackets.

    Parameters
    ----------
    column : str
        Column name with an optional unit suffix (``dyn_load_max_kN``).
    currency : str, optional
        The currency that ends the names of costs (``life_cycle_cost_EUR``,
        `trackdyn.units.money_name`).

    Returns
    -------
    str
        ``"ΔP max\\n[kN]"`` for a known quantity and unit, ``"tamped\\n[m]"`` for
        ``tamped_m``; words without underscores (``"tamping cost"``) where the name has no
        unit suffix; ``factor_k_ss`` (a parameter's factor) as ``"factor k_ss"``.
    """
    if column.startswith("factor_"):
        return f"factor {column.removeprefix('factor_')}"
    units = HEADER_UNITS if currency is None else {f"_{currency}": currency, **HEADER_UNITS}
    for suffix, unit in units.items():
        if column.endswith(suffix):
            stem = column.removesuffix(suffix)
            return f"{_words(stem)}\n[{unit}]"
    return _words(column)


def _words(name: str) -> str:
    return SHORT_NAMES.get(name, name.replace("_", " "))

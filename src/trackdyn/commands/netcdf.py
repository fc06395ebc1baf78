"""netCDF files: CF-1.8, with the run's provenance, opened labelled by plain xarray.

Every command writes its Datasets through `write_netcdf`, which makes the file follow the
CF conventions 1.8 (checked by the IOOS compliance checker in the tests) without changing
the Dataset the command goes on to plot, so that ``xr.open_dataset`` gives it back
labelled (``ds.wheel_load.sel(contact="FL")``):

- global attributes ``Conventions``, ``title``, ``history`` (the date and the command
  line), ``date_created``, ``source``, the versions of trackdyn, Python and the packages
  that shape results (``<name>_version``, `trackdyn.provenance.versions`), and from the
  output folder's `trackdyn.commands.staging.Record` every input file (``input_<name>``
  path and ``input_<name>_sha256``), the options (``option_<name>``) and the vehicle
  parameters (``vehicle_<name>`` [SI]); lists and tables as JSON text, an attribute that
  is None left out (`_attribute`);
- every dimension has an index coordinate: a dimension labelled by names (``contact``,
  ``rail``, ``dof``, ...) keeps its names, written as CF 6.1 labels (character arrays,
  which xarray reads back as strings); a dimension without a coordinate gets as index the
  one strictly increasing coordinate along it (``sleeper``: the positions of
  ``sleeper_distance``, so that ``ds.settlement.plot()`` draws against distance), else an
  integer index (``segment``, ``step``);
- no ``_FillValue`` on coordinates; 64-bit integers as 32-bit; counts held as floats
  (`COUNTS`) as integers of unit ``1``; every variable has a ``long_name`` (in words from
  `trackdyn.commands.names` where the Dataset gives none) and, where the name ends in a
  unit (``dyn_load_sd_kN``, ``tamped_m_per_100_mgt``), its ``units``, read whole from the
  name by the unit registry (`trackdyn.units.name_unit`); every ``units`` is parsed by the
  registry and written in UDUNITS spelling (`trackdyn.units.udunits`: ``MGT``, million
  gross tonnes, as ``Mt``), except a cost's: a variable whose ``currency`` attribute names
  one (`trackdyn.units.currency`) has it as its ``units`` (UDUNITS has no currency);
- a run's time axis is ``time`` in seconds from its start (no reference date: CF 1.8, 4.4,
  tells calendar time by units ``<unit> since <date>``);
- the attributes that say how long parts of the computation took (`WALL_CLOCK`) are left
  out of the file; with ``SOURCE_DATE_EPOCH`` set (the date written) two identical runs
  write identical files; the command's summary (``summary.json``) keeps the timings.

`read_netcdf` reads a file into memory.

References
----------
Eaton, B. et al. (2018), NetCDF Climate and Forecast (CF) Metadata Conventions, version
1.8, https://cfconventions.org/Data/cf-conventions/cf-conventions-1.8/cf-conventions.html
"""

from __future__ import annotations

import json

import numpy as np

from trackdyn.commands.names import words
from trackdyn.commands.staging import as_json, record_of
from trackdyn.provenance import utc_now, versions
from trackdyn.units import currency, name_unit, udunits

CONVENTIONS = "CF-1.8"
COUNTS = ("tampings", "renewals", "possessions", "interventions")
"""Variables that count events: written as integers of unit ``1`` where the Dataset holds
them as floats (a table's column)."""
WALL_CLOCK = ("time_vehicle_runs_s", "time_beam_solves_s", "time_bookkeeping_s")
"""Attributes of a deterioration result that say how long its parts took [s]."""


def timings(ds) -> dict[str, float]:
    """The attributes of ``ds`` that say how long parts of its computation took [s]."""
    return {k: float(v) for k, v in ds.attrs.items() if k in WALL_CLOCK}


def _attribute(value):
    """A value netCDF stores (None: none, the attribute is left out): numbers and text as
    they are, true and false as ``"true"`` and ``"false"``, lists and tables as JSON text."""
    if isinstance(value, bool | np.bool_):
        return str(bool(value)).lower()
    if isinstance(value, int | float | str | np.integer | np.floating) or value is None:
        return value
    return json.dumps(as_json(value), allow_nan=False)


def _attributes(attrs: dict) -> dict:
    """``attrs`` as netCDF stores them (`_attribute`), those that are None left out."""
    return {k: _attribute(v) for k, v in attrs.items() if v is not None}


def _describe(var, name: str) -> None:
    """Give ``var`` a long_name and CF units (in place, on the file's copy)."""
    stem, unit = name_unit(name)
    attrs = var.attrs
    code = attrs.pop("currency", None)
    if code is not None:
        attrs["units"] = currency(str(code))
        stem = name.removesuffix(f"_{code}")
    elif "units" not in attrs and unit is not None and var.dtype.kind in "fiu":
        attrs["units"] = unit
    if "units" in attrs and code is None:
        attrs["units"] = udunits(str(attrs["units"]))
    if "long_name" not in attrs:
        attrs["long_name"] = words(name if code is None else stem)
    positive = attrs.pop("positive", None)  # CF: an attribute of vertical coordinates only
    if positive:
        attrs["long_name"] += f", {positive} positive"


def _index(ds, dim: str):
    """The index coordinate of a dimension that has none: the one strictly increasing
    numeric coordinate along it (``sleeper_distance`` for ``sleeper``), else 0, 1, 2..."""
    along = [
        c for c in ds.coords.values()
        if c.dims == (dim,) and c.dtype.kind == "f" and np.all(np.diff(c.values) > 0)
    ]  # fmt: skip
    if len(along) == 1:
        c = along[0]
        return (dim, c.values, {"long_name": words(str(c.name)), **c.attrs})
    index = np.arange(ds.sizes[dim], dtype=np.int32)
    return (dim, index, {"long_name": f"{dim} index (0: first)"})


def to_cf(ds, record=None):
    """The Dataset as `write_netcdf` writes it (a copy; ``ds`` is left as it is).

    Parameters
    ----------
    ds : xarray.Dataset
        A command's result.
    record : trackdyn.commands.staging.Record, optional
        The run's provenance, for the global attributes.
    """
    out = ds.copy()
    out.attrs = _attributes({k: v for k, v in ds.attrs.items() if k not in WALL_CLOCK})
    for dim in list(out.dims):
        if dim in out.coords and out[dim].dtype.kind in "UO":
            out[dim].attrs.setdefault("long_name", f"{dim} name")
        if dim not in out.indexes:
            out = out.assign_coords({dim: _index(out, dim)})
    for name, var in out.variables.items():
        if var.dtype.kind in "iu" and var.dtype.itemsize > 4:
            if var.size and np.abs(var.values).max() >= 2**31:
                raise ValueError(f"{name}: integers beyond 32 bits")
            out[name] = var.astype(np.int32)
        if str(name) in COUNTS and var.dtype.kind == "f" and _whole(var.values):
            out[name] = var.astype(np.int32)
        if str(name) in COUNTS:
            out[name].attrs.setdefault("units", "1")
        _describe(out[name].variable, str(name))
    if "time" in out.variables:
        out["time"].attrs["long_name"] = "time from the start of the run"
    out.attrs.update(global_attributes(out.attrs.get("title"), record))
    return out


def _whole(values) -> bool:
    """Every value a whole number that 32 bits hold (a count stored as float)."""
    return bool(np.all(np.isfinite(values) & (values == np.round(values))))


def labels(ds) -> list[str]:
    """The coordinates of ``ds`` that label a dimension with names (``contact``)."""
    return [str(d) for d in ds.dims if d in ds.coords and ds[d].dtype.kind in "UO"]


def global_attributes(title: str | None, record=None) -> dict:
    """CF and provenance attributes of a file.

    Parameters
    ----------
    title : str, optional
        Title; default the record's.
    record : trackdyn.commands.staging.Record, optional
        The run's provenance.
    """
    from trackdyn import __version__

    created = record.created if record else utc_now()
    attrs = {
        "Conventions": CONVENTIONS,
        "title": title or (record.title if record else "trackdyn result"),
        "history": f"{created} {record.command_line if record else 'trackdyn'}",
        "date_created": created,
        "source": f"trackdyn {__version__}",
        **{f"{name}_version": v for name, v in versions().items()},
    }
    if record is not None:
        for name, (path, digest) in record.input_digests().items():
            attrs[f"input_{name}"] = path
            attrs[f"input_{name}_sha256"] = digest
        attrs.update({f"option_{k}": v for k, v in record.options.items()})
        attrs.update({f"vehicle_{k}": v for k, v in record.vehicle.items()})
    return _attributes(attrs)


def write_netcdf(ds, path) -> None:
    """Write a Dataset to netCDF-4 as the module docstring says, uncompressed.

    Simulated float64 time series are mostly noise in their last digits: zlib saved about
    20 % of a 1 km run's file (24.5 against 31 MB) and took 0.9 s against 0.07 s to write.

    Parameters
    ----------
    ds : xarray.Dataset
        A command's result.
    path : Path
        The file, in a command's staging folder
        (`trackdyn.commands.staging.output_folder`), whose record gives the provenance.
    """
    record = record_of(path)
    out = to_cf(ds, record)
    if record is not None:
        record.timings.update(timings(ds))
    encoding: dict[str, dict] = {name: {"_FillValue": None} for name in out.coords}
    for name in labels(out):  # CF 6.1 labels: character arrays, read back as strings
        encoding[name]["dtype"] = "S1"
    out.to_netcdf(path, format="NETCDF4", encoding=encoding)


def read_netcdf(path):
    """A file written by `write_netcdf`, loaded into memory (the file closed): the
    command's Dataset, names as coordinates.

    Parameters
    ----------
    path : path
        The netCDF file.
    """
    import xarray as xr

    return xr.load_dataset(path)

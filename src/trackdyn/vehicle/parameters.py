"""Vehicle parameter sets in the thesis's symbols (Fröhling, 1997), SI units, read from TOML.

References
----------
Fröhling, R.D. (1997). Deterioration of railway track due to dynamic vehicle loading and
spatially varying track stiffness. PhD thesis, University of Pretoria,
§5.4 (the symbols of eqs 5.19-5.33).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path

from trackdyn.errors import TrackdynInputError, shown, unknown
from trackdyn.io import read_toml
from trackdyn.limits import VEHICLE, check_within
from trackdyn.units import GRAVITY, si_value

# SI unit of each parameter, and a description for docs and error messages.
PARAMETERS: dict[str, tuple[str, str]] = {
    "m1": ("kg", "body mass"),
    "I1": ("kg m^2", "body roll inertia"),
    "Ip": ("kg m^2", "body pitch inertia"),
    "m2": ("kg", "bogie frame mass per bogie (two side frames)"),
    "I2": ("kg m^2", "bogie frame roll inertia"),
    "mw1": ("kg", "mass of one wheelset"),
    "Iw1": ("kg m^2", "roll inertia of one wheelset"),
    "Isf": ("kg m^2", "pitch inertia of one side frame about its centre (full model only)"),
    "k1": ("N/m", "secondary spring stiffness per side of a bogie"),
    "kp": ("N/m", "primary stiffness per side of a bogie (two axleboxes)"),
    "rho_p": ("N s/m", "primary damping per side of a bogie (two axleboxes)"),
    "rho1": ("N s/m", "viscous secondary damping per wheel (2-DOF model only)"),
    "rho2": ("N s/m", "track damping per wheel-rail contact"),
    "b": ("m", "half lateral spacing of the suspensions"),
    "b_cc": ("m", "half distance between bogie centres"),
    "l": ("m", "half distance between the wheel-rail contact points"),
    "a": ("m", "half wheelbase of a bogie"),
    "k_ss": ("N/m", "wedge (control) spring stiffness per side of a bogie"),
    "x_ss": ("m", "static compression of the wedge spring"),
    "mu": ("-", "wedge friction coefficient"),
    "alpha_w": ("rad", "wedge angle"),
    "C_slope": ("N s/m", "slope of the friction law near zero relative velocity"),
}

DERIVED: dict[str, tuple[str, str]] = {
    "mw": ("mw1", "lumped wheelset mass per bogie, 2 mw1 (5.4.3)"),
    "Iw": ("Iw1", "lumped wheelset roll inertia per bogie, 2 Iw1 (5.4.3)"),
}
"""The thesis's symbols derived from a parameter (properties of `Vehicle`): the parameter they
come from and a description, for messages."""
SHOWN_IN = {"alpha_w": ("deg", math.pi / 180)}
"""Unit (and its size in SI units) of a parameter in messages, where not its SI unit."""
PRESETS = files("trackdyn.vehicle").joinpath("presets")


@dataclass(frozen=True)
class Vehicle:
    """A vehicle parameter set (the thesis's symbols, SI units); see `PARAMETERS` for meanings.

    Build one with `load_vehicle` (preset name or TOML file) and vary it with `replace`.
    The parameters describe single wheelsets (``mw1``, ``Iw1``) and side frames (``m2 / 2``
    each, pitch inertia ``Isf``) as the full model needs them; the lumped values of the
    bogie models are derived from them (`DERIVED`: ``mw = 2 mw1``, ``Iw = 2 Iw1``).
    A value outside its plausible range (`trackdyn.limits.VEHICLE`) is refused.
    """

    m1: float
    I1: float
    Ip: float
    m2: float
    I2: float
    mw1: float
    Iw1: float
    Isf: float
    k1: float
    kp: float
    rho_p: float
    rho1: float
    rho2: float
    b: float
    b_cc: float
    l: float  # noqa: E741 - the thesis's symbol
    a: float
    k_ss: float
    x_ss: float
    mu: float
    alpha_w: float
    C_slope: float
    name: str = ""
    sources: dict = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self):
        for key, (unit, _) in PARAMETERS.items():
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise TrackdynInputError(
                    f"vehicle parameter {key} must be a number, got {shown(value)}"
                )
            unit, scale = SHOWN_IN.get(key, (unit, 1.0))
            check_within(value, *VEHICLE[key], f"vehicle parameter {key}", unit, scale)
        if self.mu >= math.tan(self.alpha_w):
            raise TrackdynInputError(
                f"vehicle parameter mu = {self.mu:g} locks the wedge: it must be below "
                f"tan(alpha_w) = {math.tan(self.alpha_w):.3f}"
            )

    @property
    def mw(self) -> float:
        """Lumped wheelset mass per bogie, ``2 mw1`` (5.4.3) [kg]."""
        return 2 * self.mw1

    @property
    def Iw(self) -> float:  # noqa: N802 - the thesis's symbol
        """Lumped wheelset roll inertia per bogie, ``2 Iw1`` (5.4.3) [kg m^2]."""
        return 2 * self.Iw1

    def replace(self, **changes) -> Vehicle:
        """A copy with some parameters changed [SI units]; an unknown name is refused."""
        for key in changes:
            _check_name(key)
        sources = dict(self.sources)
        sources.update({k: "override" for k in changes if k != "name"})
        return dataclasses.replace(self, sources=sources, **changes)

    @property
    def static_wheel_load(self) -> float:
        """Static load per wheel, ``g (m1/8 + m2/4 + mw/4)`` [N]."""
        return GRAVITY * (self.m1 / 8 + self.m2 / 4 + self.mw / 4)

    def as_dict(self) -> dict[str, float]:
        """Parameter values by name [SI units]."""
        return {k: getattr(self, k) for k in PARAMETERS}


def _check_name(key: str, where: str = "") -> None:
    """Refuse a name that is not a parameter, saying what to give for a derived one."""
    if key in DERIVED:
        source, meaning = DERIVED[key]
        raise TrackdynInputError(f"{where}{key} is derived ({meaning}): give {source} instead")
    if key not in PARAMETERS and key != "name":
        raise unknown("vehicle parameter", key, PARAMETERS, where)


def vehicle_source(name, base: Path | None = None) -> str | Path:
    """A preset name as it is, or a parameter file (``*.toml``) relative to ``base``.

    Parameters
    ----------
    name : str or Path
        Preset name (``loaded``, ``empty``, ...) or path of a vehicle ``.toml`` file.
    base : Path, optional
        Folder a relative file is taken from (the scenario's or vehicle file's folder).
    """
    if str(name).endswith(".toml"):
        return Path(base or ".") / name
    return str(name)


def vehicle_file(name_or_path) -> Path:
    """The TOML file of a vehicle: a preset's shipped file, or the file given.

    Parameters
    ----------
    name_or_path : str or Path
        Preset name or path to a ``.toml`` file.
    """
    path = Path(str(name_or_path))
    if path.suffix == ".toml":
        return path
    preset = PRESETS.joinpath(f"{name_or_path}.toml")
    if not preset.is_file():
        known = sorted(
            p.name.removesuffix(".toml") for p in PRESETS.iterdir() if p.name.endswith(".toml")
        )
        raise unknown("vehicle preset", name_or_path, known)
    return Path(str(preset))


def load_vehicle(name_or_path, **overrides) -> Vehicle:
    """Load a vehicle from a preset name (``loaded``, ``empty``, ...) or a TOML file.

    Each parameter is a table with ``value``, ``unit`` and ``source``; a file may name a
    ``base`` preset or file (relative to the file) and give only what differs.

    Parameters
    ----------
    name_or_path : str or Path
        Preset name or path to a ``.toml`` file.
    **overrides : float
        Parameter values replacing the file's [SI units].
    """
    vehicle = _load(vehicle_file(name_or_path), ())
    return vehicle.replace(**overrides) if overrides else vehicle


def _load(path: Path, below: tuple[Path, ...]) -> Vehicle:
    """The vehicle of file ``path``, on its ``base`` if it names one; ``below``: the files
    that named it as their base, in turn (a base among them is refused: a loop)."""
    data = read_toml(path)
    values, sources = {}, {}
    if "base" in data:
        named = data.pop("base")
        base = vehicle_file(vehicle_source(named, path.parent))
        chain = (*below, path)
        if base.resolve() in {f.resolve() for f in chain}:
            loop = " -> ".join(f.name for f in (*chain, base))
            raise TrackdynInputError(f"{path}: base {named!r} makes a loop of bases ({loop})")
        vehicle = _load(base, chain)
        values, sources = vehicle.as_dict(), dict(vehicle.sources)
    name = str(data.pop("name", path.stem))
    for key, entry in data.items():
        _check_name(key, f"{path}: ")
        values[key] = si_value(entry, key, PARAMETERS[key][0], str(path))
        sources[key] = str(entry["source"])
    missing = [k for k in PARAMETERS if k not in values]
    if missing:
        raise TrackdynInputError(f"{path}: missing vehicle parameter {missing[0]}")
    try:
        return Vehicle(**values, name=name, sources=sources)
    except TrackdynInputError as exc:
        raise TrackdynInputError(f"{path}: {exc}") from None

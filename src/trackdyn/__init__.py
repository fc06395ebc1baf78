"""trackdyn: railway vehicle/track vertical dynamics and track deterioration prediction.

The main calls: `load_vehicle` (a parameter set), `load_track` (a track from CSV files,
or the built-in example) and `simulate` (a vehicle model over the track, with
`RunOptions`); and the scenario objects `Run`, `Deterioration` and `Calibration`
(`trackdyn.api`: a scenario's inputs, ``.solve()``, ``.summary()``, ``.plot()``). They are
imported on first use, so the command line starts quickly.
"""

import os
import sys
from importlib import import_module
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path


def _user_cache() -> Path:
    """The user's cache folder: ``%LOCALAPPDATA%`` on Windows, ``~/Library/Caches`` on
    macOS, ``$XDG_CACHE_HOME`` (default ``~/.cache``) elsewhere."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


# Numba caches the compiled solver beside its source unless told otherwise: in
# site-packages, shared by every user of an environment and lost with it. Unless the user
# has set NUMBA_CACHE_DIR, it goes to the user's cache folder (numba reads the variable when
# it compiles; this process's children inherit it).
os.environ.setdefault("NUMBA_CACHE_DIR", str(_user_cache() / "trackdyn" / "numba"))

try:
    __version__ = version("trackdyn")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

_API = {
    "Calibration": "trackdyn.api",
    "Deterioration": "trackdyn.api",
    "Run": "trackdyn.api",
    "RunOptions": "trackdyn.options",
    "load_track": "trackdyn.data",
    "load_vehicle": "trackdyn.vehicle.parameters",
    "simulate": "trackdyn.simulation",
}
__all__ = [*_API, "__version__"]


def __getattr__(name):
    if name in _API:
        return getattr(import_module(_API[name]), name)
    raise AttributeError(f"module 'trackdyn' has no attribute {name!r}")

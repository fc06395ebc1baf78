"""trackdyn: railway vehicle/track vertical dynamics and track deterioration prediction.

The main calls: `load_vehicle` (a parameter set), `load_track` (a track from CSV files,
or the built-in example) and `simulate` (a vehicle model over the track, with
`RunOptions`). They are imported on first use, so the command line starts quickly.
"""

from importlib import import_module
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("trackdyn")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

_API = {
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

"""trackdyn: railway vehicle/track vertical dynamics and track deterioration prediction.

The main calls: `load_vehicle` (a parameter set), `load_track` (a track from CSV files,
or the built-in example) and `simulate` (a vehicle model over the track, with
`RunOptions`).
"""

from importlib.metadata import PackageNotFoundError, version

from trackdyn.data import load_track
from trackdyn.options import RunOptions
from trackdyn.simulation import simulate
from trackdyn.vehicle.parameters import load_vehicle

try:
    __version__ = version("trackdyn")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

__all__ = ["RunOptions", "load_track", "load_vehicle", "simulate", "__version__"]

"""trackdyn: railway vehicle/track vertical dynamics and track deterioration prediction."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("trackdyn")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

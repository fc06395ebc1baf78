"""Scenario files (TOML) for `trackdyn run`: vehicle, track and run options.

```toml
[vehicle]
preset = "loaded"          # or: file = "wagon.toml" (relative to this file)
overrides = { mu = 0.3 }   # seed symbols, SI units

[track]                    # omit for the built-in example section
geometry = "geometry.csv"  # distance_m,left_mm,right_mm
supports = "supports.csv"  # distance_m,rail,load_kN,deflection_mm

[run]                      # trackdyn.options.RunOptions
model = "11dof"
speed_kmh = 60
```
"""

from __future__ import annotations

from pathlib import Path

from trackdyn.io import read_toml
from trackdyn.options import RunOptions, Strict, VehicleSpec, parse


class TrackSpec(Strict):
    """``[track]``: ``geometry`` and ``supports`` CSV files; neither: the built-in example."""

    geometry: Path | None = None
    supports: Path | None = None

    def paths(self, base: Path) -> tuple[Path | None, Path | None]:
        """Both files relative to ``base`` (None where not given: the example)."""
        return tuple(None if p is None else base / p for p in (self.geometry, self.supports))

    def load(self, base: Path):
        """The track (`trackdyn.track.track.Track`)."""
        from trackdyn.data import load_track

        return load_track(*self.paths(base))


class Scenario(Strict):
    """A run scenario: ``[vehicle]``, ``[track]`` and ``[run]``."""

    vehicle: VehicleSpec = VehicleSpec()
    track: TrackSpec = TrackSpec()
    run: RunOptions = RunOptions()


def load_scenario(path=None) -> tuple[Scenario, Path]:
    """The scenario in ``path`` (the built-in example when None) and its folder.

    Parameters
    ----------
    path : path, optional
        Scenario TOML file.
    """
    if path is None:
        return Scenario(), Path.cwd()
    return parse(Scenario, read_toml(path), str(path)), Path(path).resolve().parent

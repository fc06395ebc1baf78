"""Rail sections: bending stiffness EI about the horizontal axis.

Second moments of area: 60E1 and 54E1 from EN 13674-1 profile data; 136RE from AREMA
profile figures (94.9 in^4). Young's modulus of rail steel 210 GPa (EN 13674-1 gives
210 GPa; 207 GPa is also quoted, a 1.4 % difference).

References
----------
EN 13674-1:2011+A1:2017. Railway applications - Track - Rail - Part 1: Vignole railway
rails 46 kg/m and above. CEN, Brussels.

AREMA (2023). Manual for Railway Engineering, Chapter 4: Rail. American Railway
Engineering and Maintenance-of-Way Association, Lanham, MD.
"""

from __future__ import annotations

from dataclasses import dataclass

from trackdyn.errors import unknown

E_RAIL_STEEL = 210e9
"""Young's modulus of rail steel [Pa]."""


@dataclass(frozen=True)
class RailSection:
    """A rail section.

    Parameters
    ----------
    name : str
        Designation, e.g. ``"60E1"``.
    mass : float
        Mass per metre [kg/m].
    area : float
        Cross-section area [m^2].
    second_moment : float
        Second moment of area about the horizontal axis [m^4].
    source : str
        Where the figures come from.
    """

    name: str
    mass: float
    area: float
    second_moment: float
    source: str

    @property
    def EI(self) -> float:
        """Bending stiffness with E = 210 GPa [N m^2]."""
        return E_RAIL_STEEL * self.second_moment


DEFAULT_RAIL = "60E1"
"""Rail section of every model and command unless one is given: UIC 60 (EN 13674-1)."""

RAIL_SECTIONS: dict[str, RailSection] = {
    r.name: r
    for r in (
        RailSection("60E1", 60.2, 76.71e-4, 3038e-8, "EN 13674-1"),
        RailSection("54E1", 54.81, 69.73e-4, 2337e-8, "EN 13674-1"),
        RailSection("136RE", 67.5, 85.94e-4, 3950e-8, "AREMA (94.9 in^4)"),
    )
}


def rail_section(name: str) -> RailSection:
    """Look up a rail section by name (``60E1``, ``54E1``, ``136RE``).

    Parameters
    ----------
    name : str
        Rail designation, case-insensitive.

    Returns
    -------
    RailSection
    """
    for key, section in RAIL_SECTIONS.items():
        if key.lower() == str(name).lower():
            return section
    raise unknown("rail section", name, RAIL_SECTIONS)

"""The rail as an Euler-Bernoulli beam on discrete supports, one support per sleeper.

- `trackdyn.beam.elements`: the Hermite cubic beam elements (shape functions, banded
  stiffness) both solvers assemble.
- `trackdyn.beam.static`: one static solve of a rail under wheel loads on nonlinear,
  tensionless load-deflection curves with seating gaps (Newton-Raphson with load steps);
  the deflection basin over a voided sleeper of `trackdyn track`
  (`trackdyn.track.analysis.voided_basin`).
- `trackdyn.beam.railseat`: rail-seat forces of many wheel positions over a section on
  linear tensionless springs behind gaps (an active-set solve of the change from the rest
  state on a window around each wheel, banded, several wheel positions side by side in
  the vector lanes), the inner loop of the deterioration prediction
  (`trackdyn.deterioration.ballast`).

The two solvers stay separate: the static one takes any load-deflection curve and gives
the whole rail, the windowed one is many times faster for linear springs but solves each
wheel on a window; one written through the other would not give the same numbers.
"""

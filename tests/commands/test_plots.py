"""The plotting functions' one form: ``plot_x(data, ax=None) -> Figure``, drawing on the
caller's axes when given."""

import io

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from trackdyn.plots import finished, panels
from trackdyn.plots.study import plot_speed_sweep, plot_study_matrix


def png(fig) -> bytes:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=60)
    plt.close(fig)
    return buffer.getvalue()


def speed_table():
    # three made-up runs of a speed study (the columns `trackdyn.studies.runner.gather` gives)
    return pd.DataFrame(
        {
            "speed_kmh": [40.0, 60.0, 80.0],
            "dyn_load_max_kN": [10.0, 14.0, 21.0],
            "dyn_load_min_kN": [-9.0, -13.0, -19.0],
            "dyn_load_sd_kN": [2.0, 3.0, 5.0],
            "error": ["", "", ""],
        }
    )


def matrix_table():
    # two excitation cases of one vehicle and damping; the second vehicle's run failed
    return pd.DataFrame(
        {
            "vehicle": ["loaded", "loaded", "empty"],
            "damping": ["nominal", "nominal", "nominal"],
            "case": ["i", "ii", "i"],
            "dyn_load_sd_kN": [1.0, 2.0, np.nan],
            "dyn_load_max_kN": [3.0, 5.0, np.nan],
            "error": ["", "", "vehicle parameter k1 must be > 0"],
        }
    )


def test_a_figure_drawn_on_the_callers_axes_is_the_one_drawn_on_its_own():
    own = plot_speed_sweep(speed_table())
    fig, ax = plt.subplots(figsize=own.get_size_inches())  # the size plot_speed_sweep takes
    assert plot_speed_sweep(speed_table(), ax=ax) is fig
    fig.tight_layout()
    assert png(fig) == png(own)


def test_a_figure_of_two_panels_takes_two_axes_and_refuses_three():
    own = plot_study_matrix(matrix_table())
    fig, axes = plt.subplots(1, 2, figsize=own.get_size_inches())
    assert plot_study_matrix(matrix_table(), ax=axes) is fig
    assert [len(a.patches) for a in axes] == [2, 2]  # one bar per case of the run that ran
    fig.tight_layout()
    assert png(fig) == png(own)
    _, three = plt.subplots(1, 3)
    with pytest.raises(ValueError, match="3 axes given for a figure of 1 x 2 panels"):
        plot_study_matrix(matrix_table(), ax=three)
    plt.close("all")


def test_panels_gives_the_callers_axes_shaped_as_subplots_would():
    fig, grid = plt.subplots(2, 2)
    same, axes = panels(list(grid.flat), 2, 2)
    assert same is fig and axes.shape == (2, 2) and axes[1, 0] is grid[1, 0]
    _, column = panels(grid[:, 0], 2, 1, squeeze=False)
    assert column.shape == (2, 1)
    _, one = panels(grid[0, 0])
    assert one is grid[0, 0]
    # a figure the caller made is laid out by the caller, not by the plotting function
    before = grid[0, 0].get_position().bounds
    assert finished(fig, grid) is fig and grid[0, 0].get_position().bounds == before
    plt.close(fig)

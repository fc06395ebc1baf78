"""The figure of a calibration (matplotlib, no screen needed)."""

from __future__ import annotations

from trackdyn.commands.plots import RAIL_COLOURS, plt, save


def calibration_figure(problem, result, path) -> None:
    """Measured and predicted D1-band change of each later survey and rail along the track.

    Parameters
    ----------
    problem : trackdyn.calibration.problem.Calibration
        The calibration.
    result : trackdyn.calibration.fit.FitResult
        The fit.
    path : path
        PNG file to write.
    """
    later = problem.mgt.size - 1
    fig, axes = plt.subplots(later, 2, figsize=(12, 2.6 * later + 1), sharex=True, squeeze=False)
    x, fit, start = problem.x, result.comparison, result.start_comparison
    for k in range(1, problem.mgt.size):
        role = "fitted" if problem.fitted[k] else "check"
        for r, ax in enumerate(axes[k - 1]):
            ax.plot(x, fit.measured[k, r] * 1e3, color="k", lw=0.8, label="measured")
            ax.plot(x, fit.predicted[k, r] * 1e3, color=RAIL_COLOURS[("left", "right")[r]],
                    lw=0.8, label="predicted, fitted values")  # fmt: skip
            ax.plot(x, start.predicted[k, r] * 1e3, color="0.6", lw=0.6, ls="--",
                    label="predicted, starting values")  # fmt: skip
            ax.fill_between(x, 0, 1, where=~problem.valid, color="0.9", step="mid",
                            transform=ax.get_xaxis_transform(), label="not compared")  # fmt: skip
            ax.set_title(f"{('left', 'right')[r]} rail, {problem.spec.survey[k].mgt:g} MGT "
                         f"({role})", fontsize=9)  # fmt: skip
            ax.grid(alpha=0.3)
        axes[k - 1, 0].set_ylabel("D1-band change [mm]\n(down +)")
    axes[0, 1].legend(loc="upper right", fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("distance [m]")
    fig.suptitle("Calibration: change since the first survey, D1 band (3-25 m)")
    save(fig, path)

"""A campaign's box plots say which mark is the median and which the mean (issue 40)."""

from __future__ import annotations

import numpy as np


def test_the_box_plot_legend_names_the_median_and_the_mean_as_they_are_drawn():
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba

    from hrc_drake.campaign.analysis import box_figure

    rng = np.random.default_rng(0)
    data = [("rr", rng.normal(10.0, 1.0, 20), ""), ("none", np.zeros(0), "no ok runs"),
            ("fifo", np.r_[rng.normal(12.0, 1.0, 19), 30.0], "")]
    fig = box_figure(data, "mean_time_between_products", "small")
    ax = fig.axes[0]
    legend = ax.get_legend()
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels[:2] == ["median", "mean"]
    median_handle, mean_handle = legend.legend_handles[:2]
    # the plot's medians are lines, its means markers: the legend draws them the same way
    medians = [line for line in ax.get_lines() if len(line.get_xdata()) == 2 and line.get_linestyle() == "-"
               and to_rgba(line.get_color()) == to_rgba(median_handle.get_color())]
    assert len(medians) >= 2  # one per drawn box
    for box, (_, values, _) in zip([1, 3], [data[0], data[2]], strict=True):
        line = next(m for m in medians if np.mean(m.get_xdata()) == box)
        assert line.get_ydata()[0] == np.median(values)
    means = [line for line in ax.get_lines() if line.get_marker() == mean_handle.get_marker()
             and line.get_linestyle() in ("None", "")]
    assert sorted(line.get_ydata()[0] for line in means) == sorted([np.mean(data[0][1]), np.mean(data[2][1])])
    assert to_rgba(means[0].get_markerfacecolor()) == to_rgba(mean_handle.get_markerfacecolor())
    assert to_rgba(median_handle.get_color()) != to_rgba(mean_handle.get_markerfacecolor())
    assert any("outliers" in label for label in labels) and any("quartiles" in label for label in labels)
    plt.close(fig)

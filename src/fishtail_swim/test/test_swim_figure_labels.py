"""The swim figures explain their marks: the path's line is C, the centre of mass, in the legend."""

from __future__ import annotations

import numpy as np

from fishtail_swim.offline import swim_figures


def test_the_path_figure_says_what_c_is(tmp_path, monkeypatch):
    saved = []
    monkeypatch.setattr(swim_figures, "_save", lambda figure, path: saved.append(figure) or path)
    x = np.linspace(0.0, 1.0, 20)
    swim_figures.plot_path(x, 0.01 * np.sin(x), tmp_path / "p.png", "run")
    (figure,) = saved
    axes = figure.axes[0]
    labels = axes.get_legend_handles_labels()[1]
    assert labels[0] == "path of C, the centre of mass" and labels[1:] == ["start", "end"]
    assert axes.get_title() == "Path of the centre of mass C: run"

"""The figures explain their marks: the tip path's "+" at the origin O is in the legend."""

from __future__ import annotations

import numpy as np

from fishtail_kinematics.offline import plots


def test_the_tip_path_legend_names_the_path_and_the_origin(tmp_path, monkeypatch):
    saved = []
    monkeypatch.setattr(plots, "_save", lambda figure, path: saved.append(figure) or path)
    angle = np.linspace(0.0, 2 * np.pi, 50)
    plots.plot_tip_path(0.3 + 0.01 * np.cos(angle), 0.07 * np.sin(angle), tmp_path / "t.png", "x")
    (figure,) = saved
    labels = figure.axes[0].get_legend_handles_labels()[1]
    assert labels == ["path of the tip T", "O (0, 0): ring-gear centre, the frame's origin"]
    assert figure.axes[0].get_legend() is not None

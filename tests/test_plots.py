"""The plots are legible: every axis labelled with its unit, no offset notation, no legend over the data,
exact results (error 0) drawn on the floor of a log axis and marked."""

import numpy as np
import pytest

import massprops.cli
from massprops.io.stl import write_binary
from massprops.validation import solids


@pytest.fixture
def figures(monkeypatch):
    """Every matplotlib figure saved during the test, drawn (so tick and offset texts exist)."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    saved, original = [], Figure.savefig

    def keep(self, *args, **kwargs):
        saved.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    return saved


def _legible(figure):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    canvas = FigureCanvasAgg(figure)             # the figure was closed after saving
    canvas.draw()
    renderer = canvas.get_renderer()
    axes = [ax for ax in figure.axes if ax.get_visible() and ax.has_data()]
    assert axes
    for ax in axes:
        assert "[" in ax.get_ylabel(), ax.get_ylabel()                      # a label with its unit
        if any(t.get_visible() and t.get_text() for t in ax.get_xticklabels()):
            assert "[" in ax.get_xlabel(), ax.get_xlabel()
        for axis in (ax.xaxis, ax.yaxis):
            assert "+" not in axis.get_offset_text().get_text()             # no "1e-12+2.253"
    legends = [ax.get_legend() for ax in figure.axes if ax.get_legend()] + list(figure.legends)
    assert legends
    for legend in legends:
        box = legend.get_window_extent(renderer)
        for ax in axes:
            assert not box.overlaps(ax.get_window_extent(renderer)), "a legend covers a plot"


def _row(case, triangles, seconds, smooth, exact):
    row = {"case": case, "triangles": triangles, "massprops_s": seconds, "trimesh_s": 2 * seconds}
    for tool, scale in (("massprops", 1.0), ("trimesh", 3.0)):
        row[f"{tool}_smooth"] = {"rel_max": smooth * scale}
        row[f"{tool}_exact"] = {"rel_max": exact * scale}
    return row


def test_accuracy_plot_is_legible_and_draws_exact_results(tmp_path, figures):
    from massprops.validation import accuracy
    rows = [_row("sphere", 100, 1e-3, 1e-2, 0.0), _row("sphere", 1000, 1e-2, 1e-3, 2e-16),
            _row("cube", 12, 1e-4, 0.0, 0.0)]
    accuracy.plot(rows, str(tmp_path / "a.png"))
    (figure,) = figures
    _legible(figure)
    for ax in figure.axes:
        bottom, _ = ax.get_ylim()
        assert bottom < accuracy.PLOT_FLOOR
        floor_points = [x for line in ax.get_lines() for x, y in line.get_xydata() if y == accuracy.PLOT_FLOOR
                        and line.get_marker() not in (None, "None", "")]
        assert floor_points                                              # the exact results are there
    # exact (0) on the right for sphere at 100 and both tools, and cube: 3 run times, each marked hollow
    hollow = [line for line in figure.axes[1].get_lines() if line.get_markerfacecolor() == "none"]
    assert sorted(x for line in hollow for x in line.get_xdata()) == sorted([1e-3, 2e-3, 1e-4, 2e-4])


def test_spin_plot_is_legible(tmp_path, runner, figures):
    stl = tmp_path / "bracket.stl"
    write_binary(stl, solids.l_bracket().triangles)
    result = runner.invoke(massprops.cli.main, ["spin", str(stl), "--omega", "1", "2", "0.5", "--duration", "5",
                                                "--unit", "mm", "--plot", str(tmp_path / "s.png")])
    assert result.exit_code == 0, result.output
    (figure,) = figures
    _legible(figure)
    labels = [ax.get_ylabel() for ax in figure.axes]
    assert any("kg·m²/s" in label for label in labels)                  # H in SI with --unit
    energy = figure.axes[2].get_lines()[0].get_ydata()
    assert np.abs(energy).max() < 1e-9                                   # K drawn as its relative drift


def test_spin_work_precision_plot_is_legible(tmp_path, runner, figures, box):
    result = runner.invoke(massprops.cli.main, ["spin", box, "--omega", "1", "2", "0.5", "--duration", "1",
                                                "--compare-methods", "--plot", str(tmp_path / "w.png")])
    assert result.exit_code == 0, result.output
    _legible(figures[0])

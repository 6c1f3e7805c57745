"""A :class:`~massprops.view.picture.Picture` as a PNG: front, side and top views and the numbers (matplotlib).

Three orthographic views, each with equal scales on both axes: front (x–z,
top left), side (y–z, top right), top (x–y, bottom left); the legend and the
side panel's numbers fill the fourth cell, so no legend covers the drawing.
Surfaces are filled in their colour (silhouettes); lines and markers are
drawn over them.
"""

from __future__ import annotations

from ..plotting import pyplot

__all__ = ["write_png", "VIEWS"]

# (title, horizontal axis, vertical axis, grid cell)
VIEWS = (("front (x–z)", 0, 2, (0, 0)), ("side (y–z)", 1, 2, (0, 1)), ("top (x–y)", 0, 1, (1, 0)))
_NAMES = "xyz"
_PANEL_LINES = 44


def _pyplot():
    return pyplot("the image", "pip install 'massprops[plot]' (or write a .html page, which needs plotly)")


def _view(ax, picture, h, v, limits):
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.ticker import ScalarFormatter
    for s in picture.surfaces:
        if not len(s.faces):
            continue
        triangles = s.vertices[s.faces][:, :, [h, v]]
        ax.add_collection(PolyCollection(triangles, facecolors=s.color, edgecolors=s.color, linewidths=0.3,
                                         alpha=None if s.opacity >= 0.5 else s.opacity, antialiased=False, zorder=1))
    for ln in picture.lines:
        segments = ln.segments[:, :, [h, v]]
        ax.add_collection(LineCollection(segments, colors=ln.color, linewidths=ln.width / 2 + 0.5,
                                         linestyles="--" if ln.dashed else "-", zorder=3))
    for m in picture.markers:
        if m.kind == "com":
            ax.plot(m.point[h], m.point[v], "o", color=m.color, markersize=8, markeredgecolor="black", zorder=5)
        else:
            ax.plot(m.point[h], m.point[v], "D", markerfacecolor="none", markeredgecolor=m.color, markersize=8,
                    markeredgewidth=1.5, zorder=5)
    unit = picture.length_unit
    ax.set_xlim(limits[h])
    ax.set_ylim(limits[v])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel(f"{_NAMES[h]} [{unit}]")
    ax.set_ylabel(f"{_NAMES[v]} [{unit}]")
    for axis in (ax.xaxis, ax.yaxis):
        formatter = ScalarFormatter(useOffset=False)
        formatter.set_powerlimits((-5, 6))          # plain decimals for parts in metres (0.001), no offset
        axis.set_major_formatter(formatter)
    ax.grid(True, color="#dddddd", linewidth=0.5, zorder=0)


def _limits(picture):
    """Per axis (lo, hi): the drawing's box, widened 8 % and to a common minimum span (a flat part stays visible)."""
    box = picture.bounds()
    span = box[1] - box[0]
    pad = 0.08 * max(float(span.max()), 1e-300)
    return [(float(box[0][k] - pad), float(box[1][k] + pad)) for k in range(3)]


def _kind(name):
    """A legend entry's text: a link's items share one entry ("base_link: computed box" → "computed box")."""
    return name.split(": ", 1)[1] if ": " in name else name


def _legend(cell, picture):
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    handles, seen = [], set()
    for s in picture.surfaces:
        label = _kind(s.name) if ": " in s.name else s.group
        if label not in seen and len(seen) < 6:
            seen.add(label)
            handles.append(Patch(color=s.color, alpha=min(1.0, s.opacity * 1.5), label=label))
    for ln in picture.lines:
        label = ln.label or _kind(ln.name)
        if label not in seen:
            seen.add(label)
            handles.append(Line2D([], [], color="#555555" if ": " in ln.name else ln.color,
                                  linestyle="--" if ln.dashed else "-", label=label))
    for m in picture.markers:
        label = _kind(m.name)
        if label not in seen:
            seen.add(label)
            com = m.kind == "com"
            handles.append(Line2D([], [], marker="o" if com else "D", linestyle="none",
                                  markeredgecolor="black" if com else "#555555",
                                  markerfacecolor=m.color if com and ": " not in m.name else "none" if not com
                                  else "#555555", label=label))
    cell.axis("off")
    cell.legend(handles=handles[:14], loc="upper left", fontsize=7, frameon=False)


def _panel_text(picture):
    lines = list(picture.alerts) + [", ".join(picture.columns)] if picture.rows else list(picture.alerts)
    lines += ["  ".join(str(c) for c in row.cells) for row in picture.rows[:20]]
    if len(picture.rows) > 20:
        lines.append(f"... {len(picture.rows) - 20} more rows (in the .html page)")
    if picture.panel and len(picture.rows) <= 1:
        lines += picture.panel.splitlines()
    if len(lines) > _PANEL_LINES:
        lines = lines[:_PANEL_LINES - 1] + ["..."]
    return "\n".join(line if len(line) <= 90 else line[:87] + "..." for line in lines)


def write_png(picture, path):
    """Write the picture as a PNG at ``path`` (raises MassPropsError without matplotlib)."""
    plt = _pyplot()
    fig, grid = plt.subplots(2, 2, figsize=(12, 9), dpi=100)
    try:
        limits = _limits(picture)
        for title, h, v, (row, col) in VIEWS:
            _view(grid[row][col], picture, h, v, limits)
            grid[row][col].set_title(title, fontsize=10)
        cell = grid[1][1]
        _legend(cell, picture)
        cell.text(0.0, 0.5, _panel_text(picture), family="monospace", fontsize=6.5, va="top", ha="left",
                  transform=cell.transAxes)
        fig.suptitle(picture.title, fontsize=11)
        fig.tight_layout()
        fig.savefig(path)
    finally:
        plt.close(fig)

"""A :class:`~massprops.view.picture.Picture` as one self-contained web page (plotly, the ``view`` extra).

plotly.js is embedded in the page (``include_plotlyjs=True``, about 4.7 MB),
so the file opens from disk with no network, and a CI job can keep it as an
artifact.  The side panel holds the numbers and the table; selecting a row
focuses its group (the others fade, the view zooms to it); "show all"
returns.  Opening the page as ``REPORT.html#focus=NAME`` focuses NAME at once.
"""

from __future__ import annotations

import html
import json

import numpy as np

from ..model.errors import MassPropsError

__all__ = ["write_html", "page"]

# The camera looks from +x, −y, +z: x to the right, z up.
CAMERA = {"eye": {"x": 1.4, "y": -1.4, "z": 0.9}, "up": {"x": 0, "y": 0, "z": 1}}


def _plotly():
    try:
        import plotly.graph_objects as go
        import plotly.io as pio
    except ImportError:
        raise MassPropsError("the web page needs plotly, which is not installed",
                             fix="pip install 'massprops[view]' (or write a .png, which needs matplotlib)") from None
    return go, pio


def _polyline(segments):
    """x, y, z lists of segments (k, 2, 3) joined by None breaks, as plotly draws separate segments."""
    out = [[], [], []]
    for a, b in np.asarray(segments, dtype=float):
        for axis in range(3):
            out[axis] += [float(a[axis]), float(b[axis]), None]
    return out


def _traces(picture, go):
    traces = []
    several = len(picture.rows) > 1          # a robot or a scene: the notes and the table's swatches explain colours
    for s in picture.surfaces:
        used = s.faces
        traces.append(go.Mesh3d(
            x=s.vertices[:, 0], y=s.vertices[:, 1], z=s.vertices[:, 2], i=used[:, 0], j=used[:, 1], k=used[:, 2],
            color=s.color, opacity=s.opacity, flatshading=True, name=s.name, hoverinfo="name", showlegend=not several,
            lighting={"ambient": 0.65, "diffuse": 0.5, "specular": 0.05, "roughness": 0.9},
            meta=[s.group, s.opacity]))
    for ln in picture.lines:
        x, y, z = _polyline(ln.segments)
        text = [""] * len(x)
        mode = "lines"
        if ln.label:
            text[-2] = ln.label
            mode = "lines+text"
        traces.append(go.Scatter3d(
            x=x, y=y, z=z, mode=mode, text=text, textposition="top center", name=ln.label or ln.name,
            line={"color": ln.color, "width": ln.width, "dash": "dash" if ln.dashed else "solid"},
            textfont={"color": ln.color, "size": 12}, hoverinfo="name", showlegend=not (ln.label or several),
            meta=[ln.group, 1.0]))
    for m in picture.markers:
        traces.append(go.Scatter3d(
            x=[float(m.point[0])], y=[float(m.point[1])], z=[float(m.point[2])], mode="markers", name=m.name,
            marker={"color": m.color, "size": 7 if m.kind == "com" else 6,
                    "symbol": "circle" if m.kind == "com" else "diamond-open",
                    "line": {"color": "#000000", "width": 1}},
            hoverinfo="name+x+y+z", showlegend=not several, meta=[m.group, 1.0]))
    return traces


def _side(picture):
    esc = html.escape
    parts = [f"<h1>{esc(picture.title)}</h1>"]
    parts += [f'<p class="alert">{esc(a)}</p>' for a in picture.alerts]
    parts += [f'<p class="note">{esc(n)}</p>' for n in picture.notes]
    if picture.rows:
        head = "".join(f"<th>{esc(c)}</th>" for c in picture.columns)
        body = []
        for row in picture.rows:
            style = f' style="border-left: 6px solid {row.color}"' if row.color else ""
            swatch = f'<span class="swatch" style="background: {row.swatch}"></span>' if row.swatch else ""
            cells = "".join(f"<td>{swatch if k == 0 else ''}{esc(str(c))}</td>" for k, c in enumerate(row.cells))
            body.append(f'<tr data-group="{esc(row.group)}"{style}>{cells}</tr>')
        parts.append('<p class="hint">Select a row to focus it; <a href="#" id="showall">show all</a>.</p>'
                     f'<table id="rows"><thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table>')
    if picture.panel:
        parts.append(f"<pre>{esc(picture.panel)}</pre>")
    return "\n".join(parts)


_STYLE = """
body { margin: 0; font-family: sans-serif; display: flex; height: 100vh; }
#plotbox { flex: 0 0 66%; width: 66%; min-width: 0; }
#side { flex: 0 0 34%; box-sizing: border-box; overflow: auto; padding: 6px 10px; font-size: 13px;
        border-left: 1px solid #ccc; }
h1 { font-size: 15px; word-break: break-all; }
.alert { background: #fde0dd; border-left: 4px solid #d62728; padding: 4px; }
.note { color: #444; }
table { border-collapse: collapse; font-size: 12px; }
td, th { padding: 2px 5px; border-bottom: 1px solid #eee; text-align: left; vertical-align: top; }
tr[data-group] { cursor: pointer; }
td:first-child { white-space: nowrap; }
tr.selected { background: #ffffb3; }
.swatch { display: inline-block; width: 10px; height: 10px; margin-right: 4px; border: 1px solid #888; }
pre { font-size: 11px; }
"""

_SCRIPT = """
(function () {
  var bounds = %s;
  var gd = document.getElementById('view');
  function focus(group) {
    document.querySelectorAll('tr[data-group]').forEach(function (row) {
      row.classList.toggle('selected', row.dataset.group === group);
    });
    var opacity = gd.data.map(function (t) {
      var mine = group === null || t.meta[0] === group || t.meta[0] === '';
      return mine ? t.meta[1] : 0.12;
    });
    Plotly.restyle(gd, {opacity: opacity});
    var box = group === null ? null : bounds[group];
    if (!box) {
      Plotly.relayout(gd, {'scene.xaxis.autorange': true, 'scene.yaxis.autorange': true,
                           'scene.zaxis.autorange': true, 'scene.aspectmode': 'data'});
      return;
    }
    var half = 0.0, update = {'scene.aspectmode': 'cube'};
    for (var k = 0; k < 3; k++) { half = Math.max(half, 0.65 * (box[1][k] - box[0][k])); }
    half = half > 0 ? half : 1e-3;
    ['x', 'y', 'z'].forEach(function (axis, k) {
      var mid = 0.5 * (box[0][k] + box[1][k]);
      update['scene.' + axis + 'axis.range'] = [mid - half, mid + half];
    });
    Plotly.relayout(gd, update);
  }
  document.querySelectorAll('tr[data-group]').forEach(function (row) {
    row.addEventListener('click', function () { focus(row.dataset.group); });
  });
  var all = document.getElementById('showall');
  if (all) { all.addEventListener('click', function (event) { event.preventDefault(); focus(null); }); }
  window.massprops = {focus: focus};
  if (location.hash.indexOf('#focus=') === 0) { focus(decodeURIComponent(location.hash.slice(7))); }
})();
"""


def page(picture):
    """The page's HTML text (str)."""
    go, pio = _plotly()
    fig = go.Figure(_traces(picture, go))
    unit = picture.length_unit
    fig.update_layout(
        scene={"aspectmode": "data", "camera": CAMERA, "xaxis": {"title": {"text": f"x [{unit}]"}},
               "yaxis": {"title": {"text": f"y [{unit}]"}}, "zaxis": {"title": {"text": f"z [{unit}]"}}},
        margin={"l": 0, "r": 0, "t": 30, "b": 0}, legend={"x": 0.0, "y": 1.0, "bgcolor": "rgba(255,255,255,0.6)"},
        title={"text": html.escape(picture.title), "x": 0.02, "font": {"size": 14}})
    plot = pio.to_html(fig, include_plotlyjs=True, full_html=False, div_id="view", default_width="100%",
                       default_height="100vh", config={"displaylogo": False, "responsive": True})
    groups = {row.group: picture.bounds(row.group).tolist() for row in picture.rows}
    # Names come from the files: "</" would end the script element, so it is written "<\/" (same string in JS).
    groups_json = json.dumps(groups).replace("</", "<\\/")
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\">"
            f"<title>massprops: {html.escape(picture.title)}</title><style>{_STYLE}</style></head>\n<body>"
            f'<div id="plotbox">{plot}</div>\n<div id="side">{_side(picture)}</div>\n'
            f"<script>{_SCRIPT % groups_json}</script></body></html>\n")


def write_html(picture, path):
    """Write the page to ``path`` (raises MassPropsError without plotly; OSError when it cannot be written)."""
    text = page(picture)
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(text)

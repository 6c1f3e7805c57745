"""massprops view: the geometry of the drawing (closed forms) and the PNG, checked by its pixels."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from massprops.io.stl import write_binary
from massprops.validation import solids
from massprops.view.geometry import boundary_faces, decimated, equivalent_box, equivalent_ellipsoid

from conftest import random_rotation

sides = st.floats(min_value=1e-3, max_value=1e3, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(sides, sides, sides, st.floats(min_value=1e-6, max_value=1e6))
def test_a_cuboid_gives_back_its_half_extents(a, b, c, mass):
    moments = mass / 3 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])     # uniform box, half-extents a, b, c
    extents = equivalent_box(moments, mass)
    assert extents.feasible
    # Squares come from sums and differences of the moments: their error is a few ulps of the largest square.
    assert np.allclose(extents.half ** 2, np.array([a, b, c]) ** 2, rtol=1e-12, atol=1e-14 * max(a, b, c) ** 2)


@settings(max_examples=60, deadline=None)
@given(sides, sides, sides, st.floats(min_value=1e-6, max_value=1e6))
def test_an_ellipsoid_gives_back_its_semi_axes(a, b, c, mass):
    moments = mass / 5 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    extents = equivalent_ellipsoid(moments, mass)
    assert extents.feasible
    # Squares come from sums and differences of the moments: their error is a few ulps of the largest square.
    assert np.allclose(extents.half ** 2, np.array([a, b, c]) ** 2, rtol=1e-12, atol=1e-14 * max(a, b, c) ** 2)


def test_moments_that_break_the_triangle_inequality_have_no_box():
    extents = equivalent_box([3.0, 1.0, 1.0], 1.0)          # I1 > I2 + I3
    assert not extents.feasible
    assert extents.half[0] == 0 and extents.half[1] > 0 and extents.half[2] > 0


def test_boundary_of_two_tetrahedra_and_decimation():
    faces = boundary_faces([[0, 1, 2, 3], [1, 2, 3, 4]])
    assert len(faces) == 6                                # the shared face is inside
    assert not any(sorted(f) == [1, 2, 3] for f in faces.tolist())
    kept, shown, total = decimated(np.arange(3000).reshape(1000, 3), 100)
    assert (shown, total) == (100, 1000) and len(kept) == 100 and len(np.unique(kept[:, 0])) == 100


def _part(tmp_path, mesh, name="part.stl", **options):
    from massprops import report
    from massprops import mass_properties
    from massprops.view.picture import display_triangles
    path = str(tmp_path / name)
    write_binary(path, mesh.triangles)
    result = mass_properties(path, **options)
    from massprops.io import read
    vertices, faces = display_triangles(read(path))
    return result, report.result_dict(result), vertices, faces


def test_the_drawn_box_of_a_rotated_cuboid_is_the_cuboid_and_its_axes_the_principal_axes(tmp_path):
    from massprops.model.frames import Pose
    from massprops.view.picture import part_picture
    rotation, shift = random_rotation(7), np.array([3.0, -1.0, 2.0])
    size = np.array([1.0, 2.0, 4.0])
    mesh = solids.box(tuple(size))
    corners = mesh.vertices @ rotation.T + shift                # where the cuboid's corners are, globally
    result = _part(tmp_path, mesh, pose=Pose(rotation, shift))
    picture = part_picture([result])
    box = next(ln for ln in picture.lines if ln.name.startswith("equivalent box"))
    drawn = np.unique(np.round(box.segments.reshape(-1, 3), 9), axis=0)
    assert len(drawn) == 8
    for corner in corners:
        assert np.min(np.linalg.norm(drawn - corner, axis=1)) < 1e-9
    # Principal axes ascending: the longest edge (z, 4) has the smallest moment; axis k along rotation column.
    axes = [ln for ln in picture.lines if ln.name in ("I1", "I2", "I3")]
    assert [ln.name for ln in axes] == ["I1", "I2", "I3"]
    for ln, column in zip(axes, (2, 1, 0)):
        start, end = ln.segments[0]
        assert np.allclose(start, shift)
        direction = (end - start) / np.linalg.norm(end - start)
        assert abs(abs(direction @ rotation[:, column]) - 1) < 1e-12
    com = next(m for m in picture.markers if m.kind == "com")
    assert np.allclose(com.point, shift)


def test_a_big_mesh_is_drawn_decimated_and_the_page_says_so(tmp_path):
    from massprops.view.picture import part_picture
    result = _part(tmp_path, solids.uv_sphere(64, 32))
    picture = part_picture([result], limit=500)
    total = len(result[3])
    assert picture.surfaces[0].shown == 500 < total
    assert any(f"drawn with 500 of {total} triangles" in alert for alert in picture.alerts)


def _pixels(image, color, tolerance=40):
    rgb = image[..., :3].astype(int)
    return np.all(np.abs(rgb - np.array(color)) <= tolerance, axis=-1)


def test_png_has_the_com_at_its_projected_place_and_the_axis_glyphs(tmp_path, runner):
    import matplotlib.image
    from massprops.cli import main
    wedge = solids.prism([(0, 0), (3, 0), (0, 3)], [(0, 1, 2)], 1.0)    # centre of mass (1, 1, 0.5)
    stl = str(tmp_path / "wedge.stl")
    write_binary(stl, wedge.triangles)
    png = str(tmp_path / "wedge.png")
    result = runner.invoke(main, ["view", stl, "-o", png])
    assert result.exit_code == 0, result.output
    image = (matplotlib.image.imread(png) * 255).round()
    height, width = image.shape[:2]
    front = image[: height // 2, : width // 2]                        # the front view (x–z) is top left
    part = _pixels(front, (107, 174, 214), 12)
    ys, xs = np.nonzero(part)
    left, right, top, bottom = xs.min(), xs.max(), ys.min(), ys.max()
    assert right - left > 100 and bottom - top > 20
    com_y, com_x = np.nonzero(_pixels(front, (255, 0, 255), 30))
    assert len(com_x) > 20
    # x = 1 of 0..3 (a third from the left), z = 0.5 of 0..1 (half-way)
    assert abs(com_x.mean() - (left + (right - left) / 3)) < 3
    assert abs(com_y.mean() - (top + bottom) / 2) < 3
    for color in ((228, 26, 28), (44, 160, 44), (26, 26, 255)):       # principal axes 1, 2, 3
        assert _pixels(image, color, 30).sum() > 50
    assert _pixels(image, (255, 127, 0), 30).sum() > 200              # the equivalent box


def test_view_refuses_an_unknown_output_suffix(box, runner, tmp_path):
    from massprops.cli import main
    result = runner.invoke(main, ["view", box, "-o", str(tmp_path / "out.svg")])
    assert result.exit_code == 2
    assert ".html" in result.output and ".png" in result.output


def test_view_goes_on_past_a_bad_file_and_exits_1(box, runner, tmp_path):
    from massprops.cli import main
    out = tmp_path / "out.png"
    result = runner.invoke(main, ["view", str(tmp_path / "missing.stl"), box, "-o", str(out)])
    assert result.exit_code == 1
    assert "missing.stl" in result.output and out.exists()


@pytest.mark.parametrize("glyph", ["box", "ellipsoid"])
def test_view_applies_unit_and_density(box, runner, tmp_path, glyph):
    import re
    from massprops.cli import main
    from massprops.view.html import page
    out = tmp_path / "out.png"
    result = runner.invoke(main, ["view", box, "-o", str(out), "--glyph", glyph, "--unit", "mm", "--density", "2000"])
    assert result.exit_code == 0, result.output
    from massprops import report
    from massprops import mass_properties
    from massprops.view.picture import part_picture
    from massprops.io import read
    from massprops.view.picture import display_triangles
    res = mass_properties(box, unit="mm", density=2000.0)
    picture = part_picture([(res, report.result_dict(res), *display_triangles(read(box)))], glyph=glyph)
    assert picture.length_unit == "m"
    drawn = picture.surfaces[0].vertices
    assert np.allclose(drawn.max(axis=0) - drawn.min(axis=0), [1e-3, 2e-3, 3e-3], rtol=1e-12)
    text = page(picture)
    mass = 1 * 2 * 3 * 1e-9 * 2000                                      # 1 × 2 × 3 mm at 2000 kg/m³
    assert re.search(r"mass\s+" + re.escape(f"{mass:g}"), text)


def test_scene_html_draws_every_part_and_the_total(runner, tmp_path):
    import os
    from massprops.cli import main
    from massprops.scene import assembly
    from massprops.view.scene import scene_picture
    from massprops.report.scene import scene_dict
    here = os.path.join(os.path.dirname(__file__), "..", "sample_meshes", "scene", "arm.toml")
    out = tmp_path / "arm.png"
    result = runner.invoke(main, ["scene", here, "--html", str(out)])
    assert result.exit_code == 0, result.output
    assert out.stat().st_size > 10_000
    computed = assembly.compute_scene(assembly.load_scene(here))
    picture = scene_picture(computed, scene_dict(computed))
    names = [p.name for p in computed.scene.placed_parts()]
    assert [s.name for s in picture.surfaces] == names
    total = next(m for m in picture.markers if m.name == "total centre of mass")
    assert np.allclose(total.point, computed.total.center_of_mass)
    # every part's drawn triangles enclose its centre of mass's box (the part is drawn where it is)
    for surface, props in zip(picture.surfaces, computed.parts):
        lo, hi = surface.vertices.min(axis=0), surface.vertices.max(axis=0)
        assert np.all(props.center_of_mass_global >= lo - 1e-12) and np.all(props.center_of_mass_global <= hi + 1e-12)


def test_robot_props_html_takes_one_model(runner, tmp_path):
    import os
    from massprops.cli import main
    model = os.path.join(os.path.dirname(__file__), "..", "sample_meshes", "robot", "massprops_robot", "urdf",
                         "robot.urdf")
    out = tmp_path / "robot.png"
    result = runner.invoke(main, ["robot", "props", model, "--html", str(out)])
    assert result.exit_code == 0, result.output
    assert out.stat().st_size > 10_000
    result = runner.invoke(main, ["robot", "props", model, model, "--html", str(out)])
    assert result.exit_code == 2 and "one model" in result.output


def test_a_volume_mesh_is_drawn_by_its_boundary(runner, tmp_path):
    import os
    import meshio
    from massprops.view.picture import display_triangles
    from massprops.io import read
    path = os.path.join(os.path.dirname(__file__), "..", "sample_meshes", "examples", "bar.vtu")
    vertices, faces = display_triangles(read(path))
    cells = sum(len(block.data) for block in meshio.read(path).cells)
    assert 0 < len(faces) < 4 * 6 * cells                       # boundary only, not every cell's faces
    # every edge of a closed boundary is shared by exactly two of its triangles
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)


def test_faces_that_cross_are_highlighted_only_when_they_do(tmp_path):
    from massprops.view.picture import part_picture
    apart = solids.combine(solids.box((1, 1, 1)), solids.box((1, 1, 1), (3, 0, 0)))
    across = solids.combine(solids.box((2, 2, 2)), solids.box((2, 2, 2), (1, 1, 1)))
    drawn = part_picture([_part(tmp_path, apart, "apart.stl")]).surfaces
    assert not [s for s in drawn if s.name.endswith("faces that cross")]
    picture = part_picture([_part(tmp_path, across, "across.stl")])
    (crossing,) = [s for s in picture.surfaces if s.name.endswith("faces that cross")]
    # The side faces of each cube that the other cube's faces pass through; none of the far faces.
    centres = crossing.vertices[crossing.faces].mean(axis=1)
    assert len(crossing.faces) > 0
    assert np.all(np.abs(centres - 0.5).max(axis=1) < 1.5)        # far faces (x = -1 or x = 2, ...) are not drawn
    assert any("overlapping" in alert for alert in picture.alerts)


def test_names_from_a_file_cannot_end_the_page_script():
    from massprops.view.html import page
    from massprops.view.picture import Picture, Row, Surface
    hostile = "</script><script>alert(1)</script>"
    vertices, faces = np.eye(3), np.array([[0, 1, 2]])
    picture = Picture(hostile, "m", (Surface(hostile, hostile, vertices, faces, "#6baed6"),),
                      rows=(Row(hostile, (hostile,)),), columns=("link",))
    from html.parser import HTMLParser

    class Scripts(HTMLParser):
        def __init__(self):
            super().__init__()
            self.inside, self.bodies = False, []

        def handle_starttag(self, tag, attrs):
            if tag == "script":
                self.inside = True
                self.bodies.append("")

        def handle_endtag(self, tag):
            self.inside = self.inside and tag != "script"

        def handle_data(self, data):
            if self.inside:
                self.bodies[-1] += data

    scripts = Scripts()
    scripts.feed(page(picture))
    assert scripts.bodies and not any(body.strip() == "alert(1)" for body in scripts.bodies)
    assert any("alert(1)" in body and "bounds" in body for body in scripts.bodies)    # kept, as a string


def test_without_plotly_the_page_says_how_to_get_it(box, runner, tmp_path, monkeypatch):
    import sys
    from massprops.cli import main
    monkeypatch.setitem(sys.modules, "plotly", None)
    monkeypatch.setitem(sys.modules, "plotly.graph_objects", None)
    monkeypatch.setitem(sys.modules, "plotly.io", None)
    result = runner.invoke(main, ["view", box, "-o", str(tmp_path / "out.html")])
    assert result.exit_code == 1
    assert "pip install 'massprops[view]'" in result.output and "Traceback" not in result.output

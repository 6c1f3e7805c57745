"""The README's pictures are made here, by the commands the README shows, and checked by their pixels.

Each run rewrites ``docs/view/*.png`` from the sample files, so the pictures
never drift from what the commands draw.
"""

from pathlib import Path

import numpy as np
import pytest

from massprops.cli import main

ROOT = Path(__file__).resolve().parent.parent
PICTURES = ROOT / "docs" / "view"
ROBOT = "sample_meshes/robot/massprops_robot/urdf/robot.urdf"          # relative: the titles show these


def _count(path, color, tolerance=30):
    import matplotlib.image
    image = (matplotlib.image.imread(str(path))[:, :, :3] * 255).round()
    return int(np.all(np.abs(image - np.array(color)) <= tolerance, axis=-1).sum())


@pytest.mark.parametrize("name,args,colors", [
    ("l_bracket.png", ["view", "sample_meshes/l_bracket.stl", "--unit", "mm", "--density", "7850"],
     [(107, 174, 214), (255, 0, 255), (255, 127, 0)]),                        # part, COM, equivalent box
    ("robot_check.png", ["robot", "check", ROBOT],
     [(44, 160, 44), (255, 127, 0), (214, 39, 40)]),                           # ok, mismatch, invalid boxes
])
def test_readme_pictures(name, args, colors, runner, monkeypatch):
    monkeypatch.chdir(ROOT)
    PICTURES.mkdir(exist_ok=True)
    out = f"docs/view/{name}"
    result = runner.invoke(main, args + (["-o", out] if args[0] == "view" else ["--html", out]))
    assert f"wrote {out}" in result.output, result.output
    for color in colors:
        assert _count(out, color) > 100, color


def test_readme_picture_of_the_robot_page_in_a_browser(runner, monkeypatch, tmp_path):
    """The page itself as Chromium shows it (the README's view of `robot check --html`)."""
    import shutil
    from test_view_browser import _hue, _no_script_errors, _open
    monkeypatch.chdir(ROOT)
    page = tmp_path / "report.html"
    result = runner.invoke(main, ["robot", "check", ROBOT, "--html", str(page)])
    assert f"wrote {page}" in result.output, result.output
    image, dom, console = _open(str(page), tmp_path)
    _no_script_errors(console)
    for color in ((44, 160, 44), (255, 127, 0), (214, 39, 40)):            # ok, mismatch, invalid
        assert _hue(image, color).sum() > 100, color
    for link in ("base_link", "flipped", "thin_plate", "product_sign"):
        assert link in dom
    PICTURES.mkdir(exist_ok=True)
    shutil.copyfile(tmp_path / "shot0.png", PICTURES / "robot_report_html.png")

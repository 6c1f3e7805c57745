"""The web pages in a real browser: headless Chromium opens them from disk with the network off.

Each page must draw the mesh (pixels of the part's colour where it should be),
log no JavaScript error, and carry the numbers in its text.  Chromium is
required (``.ci/run`` installs Debian's ``chromium``): without it these tests
fail, they do not skip.
"""

import os
import re
import shutil
import subprocess

import numpy as np
import pytest

from massprops.io.stl import write_binary
from massprops.validation import solids

WIDTH, HEIGHT = 1000, 700
PLOT_RIGHT = int(0.66 * WIDTH)          # the plot takes the left two thirds, the side panel the rest


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    pytest.fail("headless Chromium is needed for the page tests: apt-get install chromium (.ci/run does)")


def _open(page, tmp_path, fragment=""):
    """Load ``page`` from disk: ``(screenshot as an (h, w, 3) array, the DOM after scripts ran, console lines)``."""
    import matplotlib.image
    shot = tmp_path / f"shot{len(fragment)}.png"
    command = [_chromium(), "--headless=new", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
               "--no-first-run", "--disable-extensions", "--host-resolver-rules=MAP * ~NOTFOUND",
               "--proxy-server=127.0.0.1:9", "--enable-logging=stderr", "--v=0", f"--user-data-dir={tmp_path / 'ud'}",
               f"--window-size={WIDTH},{HEIGHT}", "--virtual-time-budget=2500", f"--screenshot={shot}",
               "--dump-dom", "file://" + os.path.abspath(page) + fragment]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert shot.exists(), done.stderr[-2000:]
    console = [line for line in done.stderr.splitlines() if ":CONSOLE" in line]
    image = (matplotlib.image.imread(str(shot))[:, :, :3] * 255).round().astype(int)
    return image, done.stdout, console


def _no_script_errors(console):
    errors = [line for line in console if "Uncaught" in line or re.search(r"\bError\b", line)]
    assert not errors, errors


def _hue(image, color, spread=45):
    """Pixels whose colour, less its grey level, is ``color``'s (shading and transparency keep the hue)."""
    rgb = image.astype(float)
    target = np.array(color, dtype=float)
    centred = rgb - rgb.mean(axis=-1, keepdims=True)
    want = target - target.mean()
    scale = (centred @ want) / (want @ want)
    return (np.linalg.norm(centred - scale[..., None] * want, axis=-1) < spread * 0.25) & (scale > 0.35)


def test_a_box_page_draws_the_box_and_its_numbers(tmp_path, runner):
    from massprops.cli import main
    stl = str(tmp_path / "box.stl")
    write_binary(stl, solids.box((2.0, 3.0, 4.0)).triangles)
    page = str(tmp_path / "box.html")
    result = runner.invoke(main, ["view", stl, "-o", page, "--density", "2"])
    assert result.exit_code == 0, result.output
    image, dom, console = _open(page, tmp_path)
    _no_script_errors(console)
    part = _hue(image, (107, 174, 214))
    part[:80] = False                                   # the legend's swatch
    ys, xs = np.nonzero(part)
    assert len(xs) > 0.05 * PLOT_RIGHT * HEIGHT, len(xs)
    assert not part[:, PLOT_RIGHT + 10:].any()          # nothing of it in the side panel
    # The box sits at the origin, the view's centre: its pixels centre on the plot.
    assert abs(xs.mean() - PLOT_RIGHT / 2) < 0.2 * PLOT_RIGHT
    assert abs(ys.mean() - HEIGHT / 2) < 0.25 * HEIGHT
    assert re.search(r"mass\s+48\b", dom)               # 2 × 3 × 4 at density 2
    assert "box.stl" in dom


URDF = """<?xml version="1.0"?>
<robot name="two_links">
  <link name="base_block">
    <inertial><mass value="8"/><inertia ixx="0.0533333" iyy="0.0533333" izz="0.0533333" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <link name="arm_block">
    <inertial><mass value="1"/><inertia ixx="0.02" iyy="0.02" izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.1 0.1 0.3"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base_block"/><child link="arm_block"/><origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_a_two_link_robot_page_draws_each_link_and_focuses_a_row(tmp_path, runner):
    from massprops.cli import main
    model = tmp_path / "two.urdf"
    model.write_text(URDF)
    page = str(tmp_path / "two.html")
    result = runner.invoke(main, ["robot", "check", str(model), "--html", page])
    assert "arm_block" in result.output
    assert os.path.exists(page), result.output
    image, dom, console = _open(page, tmp_path)
    _no_script_errors(console)
    plot = image[80:, :PLOT_RIGHT]
    base, arm = _hue(plot, (107, 174, 214)), _hue(plot, (201, 148, 199))
    assert base.sum() > 2000 and arm.sum() > 300, (base.sum(), arm.sum())
    # The arm is 0.5 m along +x, which the camera shows to the right of the base.
    assert np.nonzero(arm)[1].mean() > np.nonzero(base)[1].mean() + 50
    # Boxes coloured by status: the base is ok (green), the arm's declared inertia a mismatch (orange).
    assert _hue(plot, (44, 160, 44)).sum() > 100 and _hue(plot, (255, 127, 0)).sum() > 100
    for name in ("base_block", "arm_block", "mismatch"):
        assert name in dom
    assert re.search(r"total mass 9\b", dom)
    # Selecting the arm's row (the page's #focus=NAME runs the same code) centres the arm and fades the rest.
    focused, _, console = _open(page, tmp_path, "#focus=arm_block")
    _no_script_errors(console)
    arm_focused = _hue(focused[80:, :PLOT_RIGHT], (201, 148, 199))
    assert arm_focused.sum() > 300
    assert abs(np.nonzero(arm_focused)[1].mean() - PLOT_RIGHT / 2) < 0.15 * PLOT_RIGHT
    assert _hue(focused[80:, :PLOT_RIGHT], (107, 174, 214)).sum() < 0.1 * base.sum()
    assert (np.abs(focused[:, PLOT_RIGHT:] - (255, 255, 179)).max(axis=-1) < 8).sum() > 500   # the row highlighted

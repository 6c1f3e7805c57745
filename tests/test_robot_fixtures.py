"""The generated robots: exact values per link, every diagnosis on its fixture and none on the clean links,
write-then-check round trips, and bytes outside the inertial elements unchanged."""

import os

import numpy as np
import pytest

from massprops.robot.analyze import RobotSettings, analyze
from massprops.validation.robots import DENSITY, write_robots

U = 2.0 ** -53
FORMATS = ["urdf", "sdf", "mjcf"]


@pytest.fixture(scope="module")
def robots(tmp_path_factory):
    pytest.importorskip("mujoco")          # the MJCF robot needs it; the other formats are covered without it below
    directory = tmp_path_factory.mktemp("robots")
    expected = write_robots(directory)
    return directory, expected


@pytest.fixture(scope="module")
def plain_robots(tmp_path_factory):
    directory = tmp_path_factory.mktemp("plain_robots")
    return directory, write_robots(directory, formats=("urdf", "sdf"))


def _model(directory, expected, fmt):
    return os.path.join(directory, expected[fmt]["model"])


def _close(actual, wanted, bound, slack=0.0):
    """|actual − wanted| within the stated bound, the expected value's own rounding, and ``slack`` of its scale."""
    actual, wanted = np.asarray(actual, dtype=float), np.asarray(wanted, dtype=float)
    scale = float(np.abs(wanted).max())
    return float(np.abs(actual - wanted).max()) <= bound + U * scale + slack * scale


@pytest.mark.parametrize("fmt", ["urdf", "sdf"])
def test_props_match_the_exact_values_within_the_bounds(plain_robots, fmt):
    directory, expected = plain_robots
    result = analyze(_model(directory, expected, fmt), RobotSettings(command="props", density=DENSITY))
    checked = 0
    for link in result["links"]:
        wanted = expected[fmt]["links"][link["link"]].get("computed")
        if wanted is None:
            assert link["mass"] is None
            continue
        error = link["error"]
        assert _close(link["mass"], wanted["mass"], error["mass"]), link["link"]
        assert _close(link["center_of_mass"], wanted["center_of_mass"], error["center_of_mass"]), link["link"]
        assert _close(link["inertia_com"], wanted["inertia_com"], error["inertia_com"]), link["link"]
        checked += 1
    assert checked >= 13


def test_mjcf_props_match_the_exact_values(robots):
    # MuJoCo composes the geom frames (quaternions) in its own float arithmetic: a few ulps beyond our bound.
    directory, expected = robots
    result = analyze(_model(directory, expected, "mjcf"), RobotSettings(command="props"))
    for link in result["links"]:
        wanted = expected["mjcf"]["links"][link["link"]].get("computed")
        if wanted is None:
            continue
        error = link["error"]
        assert link["density"] == pytest.approx(DENSITY, rel=4 * U)      # the file's <default><geom density>
        assert _close(link["mass"], wanted["mass"], error["mass"])
        assert _close(link["center_of_mass"], wanted["center_of_mass"], error["center_of_mass"], 1e-14)
        assert _close(link["inertia_com"], wanted["inertia_com"], error["inertia_com"], 1e-14)


def _check(directory, expected, fmt, **settings):
    return analyze(_model(directory, expected, fmt), RobotSettings(command="check", **settings))


def _statuses_and_diagnoses(result, expected, fmt):
    got = {link["link"]: (link["status"], sorted(link["diagnoses"])) for link in result["links"]}
    want = {name: (entry["status"], sorted(entry["diagnoses"])) for name, entry in expected[fmt]["links"].items()}
    return got, want


@pytest.mark.parametrize("fmt", ["urdf", "sdf"])
def test_check_names_each_diagnosis_on_its_fixture_and_none_on_clean_links(plain_robots, fmt):
    directory, expected = plain_robots
    got, want = _statuses_and_diagnoses(_check(directory, expected, fmt), expected, fmt)
    assert got == want
    named = {d for _, diagnoses in got.values() for d in diagnoses}
    assert named == {"product_sign", "about_link_origin", "rpy_inverted", "units", "missing_scale", "transcription",
                     "triangle_inequality", "not_positive_definite"}


def test_check_mjcf_statuses_and_diagnoses(robots):
    directory, expected = robots
    got, want = _statuses_and_diagnoses(_check(directory, expected, "mjcf"), expected, "mjcf")
    assert got == want


def test_triangle_inequality_is_certified_real_or_within_rounding(plain_robots):
    directory, expected = plain_robots
    links = {link["link"]: link for link in _check(directory, expected, "urdf")["links"]}
    certified = {name: [d["certified"] for d in links[name]["diagnosis_details"] if d["name"] == "triangle_inequality"]
                 for name in ("plate", "thin_plate")}
    assert certified == {"plate": ["real"], "thin_plate": ["within rounding"]}


def test_diagnoses_are_found_by_their_transformation_not_by_the_link_name(plain_robots, tmp_path):
    # The same bad inertial under another link name is diagnosed the same.
    directory, expected = plain_robots
    path = _model(directory, expected, "urdf")
    text = open(path, encoding="utf-8").read().replace('"flipped"', '"arm_segment"')
    renamed = tmp_path / "renamed.urdf"
    renamed.write_text(text, encoding="utf-8")
    links = {link["link"]: link for link in analyze(str(renamed), RobotSettings(
        command="check", packages=(("massprops_robot", os.path.join(directory, "massprops_robot")),)))["links"]}
    assert links["arm_segment"]["diagnoses"] == ["product_sign"]


def _inertial_spans(result):
    return [(start, end) for start, end, _, _ in result.spans]


@pytest.mark.parametrize("fmt", FORMATS)
def test_write_then_check_round_trips_and_changes_only_inertial_bytes(robots, fmt, tmp_path):
    from massprops.robot.write import write_inertials
    directory, expected = robots
    path = _model(directory, expected, fmt)
    settings = RobotSettings(command="check")
    result = write_inertials(path, settings, all_links=True)
    original = open(path, "rb").read()
    # Outside the replaced spans, every byte is the original's, in order.
    outside_old, outside_new, cursor_old, cursor_new = [], [], 0, 0
    for start, end, length, _ in result.spans:
        outside_old.append(original[cursor_old:start])
        outside_new.append(result.data[cursor_new:cursor_new + start - cursor_old])
        cursor_new += start - cursor_old + length
        cursor_old = end
    outside_old.append(original[cursor_old:])
    outside_new.append(result.data[cursor_new:])
    assert outside_old == outside_new
    # What replaced each span is one inertial element (or an opened link holding one).
    cursor_new = 0
    for start, end, length, name in result.spans:
        piece = result.data[start + cursor_new:start + cursor_new + length]
        assert piece.count(b"<inertial") == 1 and piece.strip().endswith((b"</inertial>", b"/>", b"</link>")), name
        cursor_new += length - (end - start)
    written = os.path.join(os.path.dirname(path), "written" + os.path.splitext(path)[1])
    with open(written, "wb") as handle:
        handle.write(result.data)
    again = analyze(written, settings)
    statuses = {link["link"]: link["status"] for link in again["links"]}
    for name, entry in expected[fmt]["links"].items():
        if entry["status"] in ("error", "massless"):
            assert statuses[name] == entry["status"]
        else:
            assert statuses[name] == "ok", (name, statuses[name])
            assert [link for link in again["links"] if link["link"] == name][0]["diagnoses"] == []


@pytest.mark.parametrize("fmt", FORMATS)
def test_written_decimals_read_back_to_the_computed_values(robots, fmt):
    from massprops.robot.write import write_inertials
    directory, expected = robots
    path = _model(directory, expected, fmt)
    result = write_inertials(path, RobotSettings(command="check"), links_glob=["bracket"])
    assert [r["link"] for r in result.written] == ["bracket"]
    (start, end, length, _), = result.spans
    new = result.data[start:start + length].decode()
    computed = [link for link in analyze(path, RobotSettings(command="check"))["links"] if link["link"] == "bracket"][0]
    for value in np.ravel(computed["inertia_com"])[[0, 4, 8]]:
        assert repr(float(value)) in new                      # shortest round-trip form
    assert repr(float(computed["mass"])) in new or f"{computed['mass']!r}" in new


def test_mujoco_accepts_the_written_mjcf_and_agrees(robots):
    mujoco = pytest.importorskip("mujoco")
    from massprops.robot.write import write_inertials
    directory, expected = robots
    path = _model(directory, expected, "mjcf")
    result = write_inertials(path, RobotSettings(command="check"), all_links=True)
    target = os.path.join(os.path.dirname(path), "accepted.xml")
    with open(target, "wb") as handle:
        handle.write(result.data)
    model = mujoco.MjModel.from_xml_path(target)          # MuJoCo rejects A + B < C: this would raise
    for name in ("plate", "thin_plate", "negative"):
        body = model.body(name)
        wanted = expected["mjcf"]["links"][name]["computed"]
        assert body.mass[0] == pytest.approx(wanted["mass"], rel=1e-15)
        assert sorted(body.inertia) == pytest.approx(sorted(np.linalg.eigvalsh(wanted["inertia_com"])), rel=1e-9)


@pytest.fixture(scope="module")
def mujoco_and_ours(robots):
    """MuJoCo's compile of the geometry-only MJCF robot (inertia from geoms, meshes in "exact" mode), and ours."""
    mujoco = pytest.importorskip("mujoco")
    directory, _ = robots
    path = os.path.join(directory, "massprops_robot", "mjcf", "robot_geometry.xml")
    ours = {link["link"]: link for link in analyze(path, RobotSettings(command="props"))["links"]}
    return mujoco.MjModel.from_xml_path(path), ours


def test_mjcf_agrees_with_mujocos_own_exact_compile(mujoco_and_ours):
    # MuJoCo keeps float32 mesh vertices: agreement to ~1e-7 relative.
    from massprops.model.frames import quat_to_matrix
    model, ours = mujoco_and_ours
    compared = 0
    for b in range(1, model.nbody):
        name = model.body(b).name
        if ours[name]["mass"] is None:
            continue
        if ours[name]["checks"]["overlap"]:
            # MuJoCo adds its geoms up: it counts the volume they share twice, we count it once.
            assert model.body_mass[b] == pytest.approx(ours[name]["mass"] + DENSITY * ours[name]["checks"]["overlap"],
                                                       rel=1e-14), name
            continue
        rotation = quat_to_matrix(model.body_iquat[b])
        theirs = rotation @ np.diag(model.body_inertia[b]) @ rotation.T
        assert model.body_mass[b] == pytest.approx(ours[name]["mass"], rel=1e-6), name
        np.testing.assert_allclose(model.body_ipos[b], ours[name]["center_of_mass"], atol=1e-7 * ours[name]["size"])
        np.testing.assert_allclose(theirs, ours[name]["inertia_com"], atol=1e-6 * np.abs(theirs).max(), rtol=0)
        compared += 1
    assert compared >= 12


def test_mjcf_primitives_agree_with_mujoco_to_rounding(mujoco_and_ours):
    model, ours = mujoco_and_ours
    for name in ("base_link", "rounded", "plate", "about_origin"):       # box, capsule + ellipsoid: no mesh
        b = model.body(name).id
        assert model.body_mass[b] == pytest.approx(ours[name]["mass"], rel=1e-14)
        assert sorted(model.body_inertia[b]) == pytest.approx(ours[name]["principal_moments"], rel=1e-12)


def test_the_robot_total_at_zero_and_at_a_joint_value(plain_robots):
    from massprops.model.frames import Pose
    directory, expected = plain_robots
    path = _model(directory, expected, "urdf")
    # The declared masses (the unscaled mesh's own would be a billion times too heavy and hide the rest).
    zero = analyze(path, RobotSettings(command="props", density=DENSITY, mass_policy="keep"))
    links = {link["link"]: link for link in zero["links"] if link["mass"] is not None}
    assert zero["total"]["mass"] == pytest.approx(sum(link["mass"] for link in links.values()), rel=1e-14)
    assert zero["total"]["left_out"] == ["open_part"]
    moved = analyze(path, RobotSettings(command="props", density=DENSITY, mass_policy="keep",
                                        joints="joint_bracket=1.5707963267948966"))
    # Turning one link about its joint's z axis moves only that link's share of the center of mass.
    bracket = links["bracket"]
    local = np.array(bracket["center_of_mass"])
    turned = Pose.from_euler("z", [90]).rotation @ local
    shift = bracket["mass"] * (turned - local) / zero["total"]["mass"]
    bound = moved["total"]["error"]["center_of_mass"] + zero["total"]["error"]["center_of_mass"] + 4 * U * float(
        np.abs(zero["total"]["center_of_mass"]).max())
    difference = np.array(moved["total"]["center_of_mass"]) - zero["total"]["center_of_mass"]
    assert np.abs(difference - shift).max() <= bound
    assert np.abs(shift).max() > 100 * bound                 # the test can fail: the shift is well resolved


def test_the_sample_robot_is_the_generator_output(tmp_path):
    import filecmp
    from massprops.validation.robots import write_sample
    sample = os.path.join(os.path.dirname(__file__), "..", "sample_meshes", "robot")
    write_sample(tmp_path)
    names = sorted(os.path.relpath(os.path.join(d, n), tmp_path) for d, _, files in os.walk(tmp_path) for n in files)
    ours = sorted(os.path.relpath(os.path.join(d, n), sample) for d, _, files in os.walk(sample) for n in files)
    assert names == ours
    match, mismatch, errors = filecmp.cmpfiles(tmp_path, sample, names, shallow=False)
    assert mismatch == [] and errors == [], "regenerate with massprops.validation.robots.write_sample('sample_meshes/robot')"

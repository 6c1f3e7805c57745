"""Link geometry: primitives against independent closed forms, meshes with non-uniform and negative scale
against exact rational arithmetic on the scaled triangles, and the mass policy."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.model.frames import Pose
from massprops.io import obj
from massprops.robot.geometry import geometry_properties, primitive_bounds
from massprops.robot.links import MassSettings, link_properties
from massprops.robot.model import Geometry, Inertial, Decimal, Link, RobotModel
from massprops.robot.resolve import Resolver
from massprops.validation import analytic, solids
from massprops.validation.exact import exact_properties

U = 2.0 ** -53


def _within(actual, wanted, bound):
    actual, wanted = np.asarray(actual, float), np.asarray(wanted, float)
    return float(np.abs(actual - wanted).max()) <= bound + 2 * U * float(np.abs(wanted).max())


@pytest.mark.parametrize("kind,size,values", [
    ("box", {"size": (0.3, 0.2, 0.1)}, analytic.box_values((0.3, 0.2, 0.1))),
    ("sphere", {"radius": 0.07}, analytic.sphere_values(0.07)),
    ("cylinder", {"radius": 0.05, "length": 0.3}, analytic.cylinder_values(0.05, 0.3)),
    ("ellipsoid", {"radii": (0.3, 0.2, 0.1)}, analytic.ellipsoid_values((0.3, 0.2, 0.1))),
    # analytic's cone stands on z = 0; the robot cone is centred on its box: 0 ≤ z ≤ h moved down by h/2.
    ("cone", {"radius": 0.1, "length": 0.4},
     analytic.cone_values(0.1, 0.4).posed(Pose(translation=np.array([0.0, 0.0, -0.2])))),
])
def test_primitives_match_the_textbook_closed_forms(kind, size, values):
    props = geometry_properties(Geometry(kind, "collision", "g", size=size), 2700.0).props
    assert _within(props.volume, values.volume, props.error.volume)
    assert _within(props.mass, 2700 * values.volume, props.error.mass)
    assert _within(props.center_of_mass, values.center_of_mass, props.error.center_of_mass)
    assert _within(props.inertia_com, 2700 * values.inertia_com, props.error.inertia_com)


def test_capsule_is_a_cylinder_and_two_hemispheres():
    # Independent of the capsule formula: a cylinder plus a whole sphere split across the two ends.
    r, length = 0.04, 0.25
    props = geometry_properties(Geometry("capsule", "collision", "g", size={"radius": r, "length": length}), 1.0).props
    cylinder = analytic.cylinder_values(r, length)
    sphere = analytic.sphere_values(r)
    hemisphere_mass = sphere.volume / 2
    # A hemisphere's center of mass is 3r/8 from its flat face; about its flat face's center its moments equal
    # the sphere's 2/5 m r².
    offset = length / 2 + 3 * r / 8
    across = 0.4 * hemisphere_mass * r * r - hemisphere_mass * (3 * r / 8) ** 2 + hemisphere_mass * offset ** 2
    transverse = cylinder.inertia_com[0, 0] + 2 * across
    axial = cylinder.inertia_com[2, 2] + sphere.inertia_com[2, 2]
    assert props.volume == pytest.approx(cylinder.volume + sphere.volume, rel=4 * U)
    np.testing.assert_allclose(np.diag(props.inertia_com), [transverse, transverse, axial], rtol=1e-15)


def test_a_capsule_of_length_zero_is_a_sphere():
    props = geometry_properties(Geometry("capsule", "collision", "g", size={"radius": 0.1, "length": 0.0}), 1.0).props
    sphere = analytic.sphere_values(0.1)
    np.testing.assert_allclose(props.inertia_com, sphere.inertia_com, rtol=4 * U, atol=0)


def test_primitive_bounds_contain_the_solid_and_touch_it():
    pose = Pose.from_quat((0.8, 0.2, -0.4, 0.4), translation=(1.0, -2.0, 0.5))
    for kind, size, mesh in [("box", {"size": (0.3, 0.2, 0.1)}, solids.box((0.3, 0.2, 0.1))),
                             ("cylinder", {"radius": 0.1, "length": 0.4}, solids.regular_prism(720, 0.1, 0.4)),
                             ("ellipsoid", {"radii": (0.3, 0.2, 0.1)}, solids.ellipsoid((0.3, 0.2, 0.1), 256, 128))]:
        bounds = primitive_bounds(Geometry(kind, "collision", "g", pose=pose, size=size))
        points = pose.apply(mesh.vertices)
        assert np.all(points >= bounds[0] - 1e-12) and np.all(points <= bounds[1] + 1e-12), kind
        assert np.allclose(points.min(axis=0), bounds[0], atol=1e-4) and np.allclose(points.max(axis=0), bounds[1],
                                                                                      atol=1e-4), kind


def test_bad_primitive_sizes_are_refused():
    from massprops.model.errors import MassPropsError
    for size in ({"size": (0.1, 0.0, 0.1)}, {"size": (0.1, -0.2, 0.1)}, {"size": (0.1, float("nan"), 0.1)}):
        with pytest.raises(MassPropsError, match="not positive"):
            geometry_properties(Geometry("box", "collision", "g", size=size, where="collision 'g'"), 1.0)


dyadic = st.sampled_from([0.25, 0.5, 1.5, 2.0, 3.0, -0.5, -1.0, -2.0])


@settings(max_examples=25, deadline=None)
@given(st.tuples(dyadic, dyadic, dyadic))
def test_mesh_scale_is_exact_even_non_uniform_and_negative(tmp_path_factory, scale):
    # Dyadic factors scale float coordinates exactly, so exact arithmetic on the scaled triangles is the oracle;
    # an odd number of negative factors mirrors the mesh and flips its winding.
    folder = tmp_path_factory.mktemp("scale")
    mesh = solids.posed(solids.l_bracket(), Pose.from_quat((0.8, 0.2, -0.4, 0.4), translation=(0.3, -0.1, 0.2)))
    path = folder / "part.obj"
    obj.write(path, mesh.vertices, mesh.faces)
    geometry = Geometry("mesh", "collision", "g", uri=str(path), scale=tuple(Fraction(s) for s in scale))
    props = geometry_properties(geometry, 1.0, resolver=Resolver(str(path))).props
    triangles = mesh.vertices[mesh.faces] * np.array(scale)
    if np.prod(scale) < 0:
        triangles = triangles[:, ::-1]
    exact = exact_properties(triangles)
    assert _within(props.volume, float(exact["volume"]), props.error.volume)
    assert _within(props.center_of_mass, [float(x) for x in exact["center_of_mass"]], props.error.center_of_mass)
    assert _within(props.inertia_com, [[float(x) for x in row] for row in exact["inertia_com"]],
                   props.error.inertia_com)


def test_a_decimal_scale_is_applied_as_the_decimal(tmp_path):
    # scale="0.001" is 1/1000 exactly, not the float nearest it: the volume is the exact one, rounded once.
    mesh = solids.box((30.0, 20.0, 10.0))
    path = tmp_path / "box_mm.obj"
    obj.write(path, mesh.vertices, mesh.faces)
    geometry = Geometry("mesh", "collision", "g", uri=str(path), scale=(Fraction("0.001"),) * 3)
    props = geometry_properties(geometry, 1.0, resolver=Resolver(str(path))).props
    assert props.volume == float(Fraction(6000) / 10 ** 9)


def _model(link):
    return RobotModel("m.urdf", "urdf", "m", (link,))


def test_keep_spreads_the_declared_mass_by_the_geometries_masses():
    box = Geometry("box", "collision", "a", size={"size": (0.1, 0.1, 0.1)}, density=1000.0)
    heavy = Geometry("box", "collision", "b", pose=Pose(translation=np.array([0.5, 0.0, 0.0])),
                     size={"size": (0.1, 0.1, 0.1)}, density=3000.0)
    declared = Inertial(Decimal("8", 8.0), np.zeros(3), np.eye(3), np.eye(3), {})
    link = Link("l", (box, heavy), declared)
    keep = link_properties(_model(link), link, MassSettings(policy="keep"), None)
    density = link_properties(_model(link), link, MassSettings(policy="density"), None)
    assert keep.props.mass == 8.0 and density.props.mass == pytest.approx(4.0)
    # The densities' ratio 1:3 survives: the COM sits three quarters of the way to the heavy box.
    assert keep.props.center_of_mass[0] == pytest.approx(0.375, rel=1e-15)
    assert [g["mass"] for g in keep.geometries] == pytest.approx([2.0, 6.0])


def test_a_link_without_density_says_it_assumed_water():
    link = Link("l", (Geometry("sphere", "collision", "s", size={"radius": 0.1}),))
    result = link_properties(_model(link), link, MassSettings(), None)
    assert result.props.density == 1000.0
    assert result.assumed_density          # analyze warns once per model (tests/test_robot_messages.py)
    given = link_properties(_model(link), link, MassSettings(density=7850.0), None)
    assert given.props.density == 7850.0 and not given.warnings and not given.assumed_density

"""The fixture robots' files: meshes and the URDF, SDF and MJCF texts (see :mod:`massprops.robot.fixtures`).

Numbers are written with ``repr`` (or as the decimal strings the fixtures give),
so every file reads back to exactly the values the expected ones are computed from.
"""

from __future__ import annotations

import math
import os
from fractions import Fraction

import numpy as np

from ..robot.model import rpy_rotation

DENSITY = 2700                      # kg/m³, aluminium
PACKAGE = "massprops_robot"
EIGHTH = Fraction(1, 16)            # the meshes are the reference solids at 1/16 scale: exact in binary

__all__ = ["mesh_files", "urdf", "sdf", "mjcf", "DENSITY", "PACKAGE"]

BRACKET = "bracket.obj"
BRACKET_MM = "bracket_mm.obj"
OPEN = "open_box.obj"
PRISM = "prism.stl"

def rational(text):
    return Fraction(str(text))


def matrix(rows):
    return [[Fraction(float(x)) for x in row] for row in rows]


def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def transpose(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


ELEMENTS = {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}


def shortest(value):
    value = float(value)
    return "0" if value == 0 else repr(value)


def mesh_files(folder, used):
    """Write the meshes named in ``used`` into ``folder``; ``{name: path}``."""
    from . import solids
    from ..io import obj, stl
    os.makedirs(folder, exist_ok=True)
    bracket, box, prism = solids.l_bracket(), solids.box((0.05, 0.05, 0.05)), solids.regular_prism(8, 0.03, 0.04)
    writers = {
        BRACKET: lambda path: obj.write(path, bracket.vertices * float(EIGHTH), bracket.faces,
                                         comment="massprops reference L-bracket at 1/16 scale (metres)"),
        BRACKET_MM: lambda path: obj.write(path, bracket.vertices * float(EIGHTH * 1000), bracket.faces,
                                            comment="the same L-bracket in millimetres"),
        # 11 of the box's 12 triangles: open.
        OPEN: lambda path: obj.write(path, box.vertices, box.faces[:-1], comment="a box with one triangle missing"),
        PRISM: lambda path: stl.write_binary(path, prism.triangles.astype(np.float32),
                                              header=b"massprops octagonal prism"),
    }
    paths = {}
    for name in sorted(used):
        paths[name] = os.path.join(folder, name)
        writers[name](paths[name])
    return paths


# -- writers per format ---------------------------------------------------------------

_SHAPE_XML = {
    "urdf": {"mesh": '<mesh filename="package://{package}/meshes/{mesh}"{scale}/>', "box": '<box size="{size}"/>',
             "sphere": '<sphere radius="{radius}"/>',
             "other": '<{kind} radius="{radius}" length="{length}"/>', "scale": ' scale="{}"'},
    "sdf": {"mesh": "<mesh><uri>model://{package}/meshes/{mesh}</uri>{scale}</mesh>",
            "box": "<box><size>{size}</size></box>", "sphere": "<sphere><radius>{radius}</radius></sphere>",
            "ellipsoid": "<ellipsoid><radii>{radii}</radii></ellipsoid>",
            "other": "<{kind}><radius>{radius}</radius><length>{length}</length></{kind}>", "scale": "<scale>{}</scale>"},
}


def _shape_xml(shape, fmt):
    """A shape's element inside ``<geometry>``, in URDF or SDF."""
    templates = _SHAPE_XML[fmt]
    values = {key: " ".join(value) if isinstance(value, tuple) else value for key, value in shape.size.items()}
    scale = templates["scale"].format(" ".join(shape.scale)) if shape.scale else ""
    return templates.get(shape.kind, templates["other"]).format(package=PACKAGE, mesh=shape.mesh, scale=scale,
                                                                kind=shape.kind, **values)


def _urdf_geometry(shape, role, indent):
    return (f'{indent}<{role}>\n{indent}  <origin xyz="{" ".join(shape.xyz)}" rpy="{" ".join(shape.rpy)}"/>\n'
            f'{indent}  <geometry>{_shape_xml(shape, "urdf")}</geometry>\n{indent}</{role}>\n')


def _texts(entry):
    """``(mass, center, rpy, {element: text})`` of a declared entry, the elements as the file writes them."""
    mass, center, tensor, rpy, texts = entry
    return mass, center, rpy, {name: texts.get(name, shortest(tensor[i][j])) for name, (i, j) in ELEMENTS.items()}


def urdf(specs, declared):
    """The URDF text of the links ``specs`` with their ``declared`` inertials."""
    lines = ['<?xml version="1.0"?>\n', '<!-- massprops robot fixture: see expected.json beside the package -->\n',
             '<robot name="massprops_robot">\n']
    for spec in specs:
        lines.append(f'  <link name="{spec.name}">\n')
        if spec.name in declared:
            mass, center, rpy, e = _texts(declared[spec.name])
            lines.append(f'    <inertial>\n      <origin xyz="{" ".join(shortest(x) for x in center)}" '
                         f'rpy="{" ".join(rpy)}"/>\n      <mass value="{shortest(mass)}"/>\n      <inertia '
                         + " ".join(f'{k}="{v}"' for k, v in e.items()) + '/>\n    </inertial>\n')
        for shape in spec.shapes:
            lines.append(_urdf_geometry(shape, "collision", "    "))
        lines.append("  </link>\n")
    for k, spec in enumerate(specs[1:], 1):
        kind = "fixed" if spec.joint == "fixed" else "revolute"
        limit = '\n    <limit lower="-3" upper="3" effort="10" velocity="1"/>' if kind == "revolute" else ""
        lines.append(f'  <joint name="joint_{spec.name}" type="{kind}">\n    <parent link="base_link"/>\n'
                     f'    <child link="{spec.name}"/>\n    <origin xyz="{0.1 * k:.1f} 0 0.1" rpy="0 0 0"/>\n'
                     f'    <axis xyz="0 0 1"/>{limit}\n  </joint>\n')
    lines.append("</robot>\n")
    return "".join(lines)


def _pose(xyz, rpy):
    return f'{" ".join(xyz)} {" ".join(rpy)}'


def _sdf_geometry(shape, role, name, indent, density=None):
    body = _shape_xml(shape, "sdf")
    # A second geometry's pose in degrees, a third's as a quaternion (x y z w): both SDF forms exercised.
    if name.endswith("_1"):
        angles = " ".join(repr(math.degrees(float(a))) for a in shape.rpy)
        pose = f'<pose degrees="true">{" ".join(shape.xyz)} {angles}</pose>'
    elif name.endswith("_2"):
        from ..model.frames import Pose
        quaternion = Pose(rpy_rotation([float(rational(a)) for a in shape.rpy])).as_quat(scalar_first=False)
        pose = (f'<pose rotation_format="quat_xyzw">{" ".join(shape.xyz)} '
                f'{" ".join(shortest(x) for x in quaternion)}</pose>')
    else:
        pose = f"<pose>{_pose(shape.xyz, shape.rpy)}</pose>"
    extra = f"<density>{density}</density>" if density is not None else ""
    return f'{indent}<{role} name="{name}">{pose}{extra}<geometry>{body}</geometry></{role}>\n'


def sdf(specs, declared):
    """The SDF text (links placed relative to a frame, poses in all three forms)."""
    lines = ['<?xml version="1.0"?>\n', '<sdf version="1.11">\n', f'  <model name="{PACKAGE}">\n',
             '    <frame name="rail"><pose>0.05 0 0.1 0 0 0</pose></frame>\n']
    for k, spec in enumerate(specs):
        # Links sit relative to a frame (relative_to), and the rail frame is itself off the model origin.
        lines.append(f'    <link name="{spec.name}">\n')
        lines.append(f'      <pose relative_to="rail">{0.1 * k:.1f} 0 0 0 0 0</pose>\n' if k else "")
        if spec.name == "rounded":
            lines.append('      <inertial auto="true"/>\n')
        elif spec.name in declared:
            mass, center, rpy, e = _texts(declared[spec.name])
            lines.append(f'      <inertial>\n        <pose>{" ".join(shortest(x) for x in center)} {" ".join(rpy)}</pose>\n'
                         f'        <mass>{shortest(mass)}</mass>\n        <inertia>'
                         + "".join(f"<{k}>{v}</{k}>" for k, v in e.items()) + "</inertia>\n      </inertial>\n")
        for j, shape in enumerate(spec.shapes):
            lines.append(_sdf_geometry(shape, "collision", f"{spec.name}_collision_{j}", "      ",
                                       DENSITY if spec.name == "rounded" else None))
        lines.append("    </link>\n")
    for spec in specs[1:]:
        kind = "fixed" if spec.joint == "fixed" else "revolute"
        lines.append(f'    <joint name="joint_{spec.name}" type="{kind}"><parent>base_link</parent>'
                     f'<child>{spec.name}</child><axis><xyz>0 0 1</xyz></axis></joint>\n')
    lines.append("  </model>\n</sdf>\n")
    return "".join(lines)


def _mjcf_geom(shape):
    quat = " ".join(shortest(x) for x in _quat(shape.rpy))
    common = f'pos="{" ".join(shape.xyz)}" quat="{quat}"'
    if shape.kind == "mesh":
        return f'<geom type="mesh" mesh="{_mesh_name(shape)}" {common}/>'
    if shape.kind == "box":
        half = " ".join(shortest(rational(x) / 2) for x in shape.size["size"])
        return f'<geom type="box" size="{half}" {common}/>'
    if shape.kind == "sphere":
        return f'<geom type="sphere" size="{shape.size["radius"]}" {common}/>'
    if shape.kind == "ellipsoid":
        return f'<geom type="ellipsoid" size="{" ".join(shape.size["radii"])}" {common}/>'
    half = shortest(rational(shape.size["length"]) / 2)
    return f'<geom type="{shape.kind}" size="{shape.size["radius"]} {half}" {common}/>'


def _quat(rpy):
    from ..model.frames import Pose
    return Pose(rpy_rotation([float(rational(a)) for a in rpy])).as_quat()


def _mesh_name(shape):
    scale = "_".join(s.replace("-", "m").replace(".", "p") for s in shape.scale) if shape.scale else "1"
    return f"{os.path.splitext(shape.mesh)[0]}_{scale}"


def mjcf(specs, declared, *, geometry_only=False):
    """The MJCF text; ``geometry_only`` leaves the inertials to MuJoCo (exact mesh inertia) for cross-checks."""
    meshes = {}
    for spec in specs:
        for shape in spec.shapes:
            if shape.kind == "mesh" and shape.mesh != OPEN:
                meshes[_mesh_name(shape)] = shape
    lines = ['<mujoco model="massprops_robot">\n',
             '  <compiler angle="radian" meshdir="../meshes"'
             + (' inertiafromgeom="true"' if geometry_only else "") + "/>\n",
             f'  <default><geom density="{DENSITY}"/></default>\n', "  <asset>\n"]
    for name, shape in meshes.items():
        scale = f' scale="{" ".join(shape.scale)}"' if shape.scale else ""
        exact = ' inertia="exact"' if geometry_only else ""
        lines.append(f'    <mesh name="{name}" file="{shape.mesh}"{scale}{exact}/>\n')
    lines.append("  </asset>\n  <worldbody>\n")
    base, others = specs[0], [s for s in specs[1:] if s.shapes or s.name == "tool0"]
    if geometry_only:
        others = [s for s in others if s.computes and s.shapes]
    lines.append(f'    <body name="{base.name}">\n')
    lines += _mjcf_body_inside(base, declared, geometry_only, "      ")
    for k, spec in enumerate(others, 1):
        if spec.name == "open_part" or (spec.shapes and spec.shapes[0].mesh == OPEN):
            continue
        lines.append(f'      <body name="{spec.name}" pos="{0.1 * k:.1f} 0 0.1">\n')
        if spec.joint != "fixed":
            lines.append(f'        <joint name="joint_{spec.name}" type="hinge" axis="0 0 1"/>\n')
        lines += _mjcf_body_inside(spec, declared, geometry_only, "        ")
        lines.append("      </body>\n")
    lines.append("    </body>\n  </worldbody>\n</mujoco>\n")
    return "".join(lines)


def _mjcf_body_inside(spec, declared, geometry_only, indent):
    lines = []
    if not geometry_only and spec.name in declared:
        mass, center, tensor, rpy, texts = declared[spec.name]
        pos = " ".join(shortest(x) for x in center)
        if spec.declared in ("rotated", "rpy_inverted"):
            # MJCF rotates only a diagonal tensor: the principal moments in the axes of quat.
            r = matrix(rpy_rotation([float(rational(a)) for a in rpy]))
            # The truth J: W = Rᵀ J R when written right, W = R J Rᵀ when inverted.
            truth = mul(mul(transpose(r), tensor), r) if spec.declared == "rpy_inverted" else \
                mul(mul(r, tensor), transpose(r))
            moments, axes = np.linalg.eigh(np.array([[float(x) for x in row] for row in truth]))
            if np.linalg.det(axes) < 0:
                axes[:, 2] = -axes[:, 2]
            from ..model.frames import Pose
            quat = Pose(axes).as_quat()
            if spec.declared == "rpy_inverted":
                quat = quat * np.array([1, -1, -1, -1])
            lines.append(f'{indent}<inertial pos="{pos}" quat="{" ".join(shortest(x) for x in quat)}" mass="{shortest(mass)}" '
                         f'diaginertia="{" ".join(shortest(x) for x in moments)}"/>\n')
        else:
            e = _texts(declared[spec.name])[3]
            full = " ".join(e[k] for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
            lines.append(f'{indent}<inertial pos="{pos}" mass="{shortest(mass)}" fullinertia="{full}"/>\n')
    for shape in spec.shapes:
        lines.append(f"{indent}{_mjcf_geom(shape)}\n")
    return lines



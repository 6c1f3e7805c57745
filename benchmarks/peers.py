"""The other tools a user could reach for, each run as a user would: a fresh process on one file.

None of them is a dependency of massprops: a peer whose package is not
installed is reported as "not installed".  What each computes differs
(meshlib gives the volume only; MuJoCo is asked for the exact mesh inertia,
not its default convex hull), which the tables say.
"""

from __future__ import annotations

import importlib.util
import sys

# MuJoCo's own STL decoder refuses files over 200,000 faces, so the triangles are read with numpy
# (a binary STL is one fromfile) and handed to MjSpec as user vertices and faces.
_MUJOCO = """
import sys, numpy, mujoco
records = numpy.fromfile(sys.argv[1], dtype=[("n", "<f4", 3), ("c", "<f4", (3, 3)), ("a", "<u2")], offset=84)
spec = mujoco.MjSpec()
mesh = spec.add_mesh(); mesh.name = "part"
mesh.uservert = records["c"].astype(numpy.float64).ravel()
mesh.userface = numpy.arange(3 * records.size, dtype=numpy.int32)
mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_EXACT
body = spec.worldbody.add_body(); body.name = "b"
geom = body.add_geom(); geom.type = mujoco.mjtGeom.mjGEOM_MESH; geom.meshname = "part"; geom.density = 1.0
model = spec.compile()
model.body_mass[1], model.body_ipos[1], model.body_inertia[1]
"""

# name: (module to look for, program run as `python -c PROGRAM FILE`, what it computes)
PEERS = {
    "trimesh": ("trimesh", "import sys, trimesh; trimesh.load(sys.argv[1]).mass_properties",
                "volume, COM, inertia"),
    "MuJoCo (MjSpec compile)": ("mujoco", _MUJOCO, "mass, COM, principal inertia (exact mesh inertia; "
                                                    "STL read by numpy.fromfile)"),
    "pymeshlab": ("pymeshlab", "import sys, pymeshlab; ms = pymeshlab.MeshSet(); ms.load_new_mesh(sys.argv[1]); "
                               "ms.get_geometric_measures()", "volume, COM, inertia"),
    "numpy-stl": ("stl", "import sys; from stl import mesh; mesh.Mesh.from_file(sys.argv[1]).get_mass_properties()",
                  "volume, COM, inertia"),
    "meshlib": ("meshlib", "import sys; import meshlib.mrmeshpy as mr; mr.loadMesh(sys.argv[1]).volume()",
                "volume only"),
}


def installed(name):
    """Whether the peer's package can be imported here."""
    return importlib.util.find_spec(PEERS[name][0]) is not None


def command(name, path):
    return [sys.executable, "-c", PEERS[name][1], path]


def meshlib_volume_seconds(path, repeat):
    """Best time of meshlib's volume of the mesh in ``path``, loaded once (in process), or None."""
    if not installed("meshlib"):
        return None
    import time
    import meshlib.mrmeshpy as mr
    mesh = mr.loadMesh(path)
    best = float("inf")
    for _ in range(repeat):
        begin = time.perf_counter()
        mesh.volume()
        best = min(best, time.perf_counter() - begin)
    return best

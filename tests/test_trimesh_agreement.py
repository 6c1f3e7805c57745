"""Agreement with trimesh on well-placed meshes (where trimesh itself is accurate)."""

import numpy as np
import pytest
import trimesh

from massprops import mass_properties
from massprops.mesh.surface import TriangleMesh


@pytest.mark.parametrize("mesh", [trimesh.creation.icosphere(3), trimesh.creation.torus(1.0, 0.3),
                                  trimesh.creation.capsule(2.0, 0.5)], ids=["icosphere", "torus", "capsule"])
def test_agrees_with_trimesh(mesh):
    ours = mass_properties(TriangleMesh(np.asarray(mesh.vertices), np.asarray(mesh.faces))).properties
    theirs = mesh.mass_properties
    assert ours.volume == pytest.approx(theirs["volume"], rel=1e-12)
    np.testing.assert_allclose(ours.center_of_mass, theirs["center_mass"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ours.inertia_com, theirs["inertia"], rtol=0, atol=1e-12 * np.abs(theirs["inertia"]).max())

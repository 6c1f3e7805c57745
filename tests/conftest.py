import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))


def random_rotation(seed):
    """A proper rotation matrix from a seeded random unit quaternion."""
    from massprops.model.frames import Pose
    q = np.random.default_rng(seed).normal(size=4)
    return Pose.from_quat(q).rotation


@pytest.fixture
def runner():
    from click.testing import CliRunner
    return CliRunner()


@pytest.fixture
def box(tmp_path):
    """A 1 × 2 × 3 box as a binary STL; its path."""
    from massprops.io.stl import write_binary
    from massprops.validation import solids
    path = tmp_path / "box.stl"
    write_binary(path, solids.box((1.0, 2.0, 3.0)).triangles)
    return str(path)

import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))


def random_rotation(seed):
    """A proper rotation matrix from a seeded random unit quaternion."""
    from massprops.frames import Pose
    q = np.random.default_rng(seed).normal(size=4)
    return Pose.from_quat(q).rotation


@pytest.fixture
def runner():
    from click.testing import CliRunner
    return CliRunner()

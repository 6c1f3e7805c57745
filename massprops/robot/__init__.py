"""Robot descriptions (URDF, xacro, SDF, MJCF): per-link mass properties, checks of declared inertials, writing them.

>>> from massprops.robot import analyze, RobotSettings
>>> report = analyze("robot.urdf", RobotSettings(command="check"))   # doctest: +SKIP
>>> [(link["link"], link["status"], link["diagnoses"]) for link in report["links"]]   # doctest: +SKIP

Modules: :mod:`.model` (the common in-memory model), :mod:`.urdf`,
:mod:`.sdf`, :mod:`.mjcf` (readers), :mod:`.resolve` (URIs),
:mod:`.geometry` (primitives and meshes), :mod:`.links` (mass policy),
:mod:`.check` (validity and diagnoses), :mod:`.kinematics` (the robot at a
joint configuration), :mod:`.write` (byte-preserving rewriting),
:mod:`.report` (text, CSV, JUnit); the generated test robots are in
:mod:`massprops.validation.robots`.
Nothing heavy is imported here; mujoco and xacro load only for MJCF and xacro.
"""

from .analyze import RobotSettings, analyze

__all__ = ["analyze", "RobotSettings"]

"""Rotational dynamics of a rigid body from its inertia: Euler's equations, the closed form, integrators.

:mod:`.body` holds the state and bookkeeping (H, K, trajectories),
:mod:`.integrators` the integrators (geometric splitting and scipy's),
:mod:`.closed_form` the torque-free Jacobi-elliptic solution, and
:mod:`.output` what a run writes.
"""

from .body import RigidBody, Trajectory, angular_momentum, euler_rhs, kinetic_energy
from .integrators import DEFAULT_METHOD, METHODS, SPLITTING, simulate, trajectory_error, work_precision

__all__ = ["RigidBody", "Trajectory", "angular_momentum", "euler_rhs", "kinetic_energy", "simulate",
           "trajectory_error", "work_precision", "METHODS", "SPLITTING", "DEFAULT_METHOD"]

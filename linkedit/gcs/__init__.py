"""A general 3D geometric constraint solver for mechanisms (after Rodgers & Booth 2021).

Members (position + unit quaternion) are held by location / orientation / axis / on-plane
constraints (and pins, welds, groups, custom Python residuals), driven by inputs interpolated
over time windows, and solved step by step by damped Gauss–Newton with analytic Jacobians.

``solve_spec(spec)`` solves a :class:`~linkedit.spec.mechanism3d.MechanismSpec`;
``simulate_numeric(linkage, t)`` (:mod:`linkedit.gcs.planar_bridge`) runs a planar linkage
through the same solver. Result files: :mod:`linkedit.io.gcs_hdf5` (``write_result``,
``read_result``).
"""

from linkedit.gcs.mechanism import check_solved, solve_spec
from linkedit.gcs.members import compile_mechanism
from linkedit.gcs.result import GcsResult
from linkedit.gcs.solve import solve_run
from linkedit.gcs.tolerances import Options
from linkedit.gcs.kernels import Custom
from linkedit.gcs.system import Elementary, State, System

__all__ = ["Custom", "Elementary", "GcsResult", "Options", "State", "System", "check_solved",
           "compile_mechanism", "solve_run", "solve_spec"]

"""Planar linkages with closed-form ("symbolic") kinematics.

``compile_plan(spec)`` orders the joints once (LinkEdit Algorithm 1); ``simulate(plan, T)``
rebuilds every joint from two known neighbours by the law of cosines
(:mod:`linkedit.planar.law_of_cosines`) over all T samples at once.
"""

from linkedit.planar.plan import Geometry, Plan, compile_plan
from linkedit.planar.simulate import Motion, Track, simulate

__all__ = ["Geometry", "Motion", "Plan", "Track", "compile_plan", "simulate"]

"""Function-preserving linkage editing (LinkEdit §4): objectives, singularity barrier, solvers.

The unknowns are free variables of the rest pose x̄ (:mod:`linkedit.edit.variables`). The
linkage's motion over the motor phases — phase 0 being x̄ itself, as in ``simulate`` — is a
function of x̄ through the reconstruction rules (:mod:`linkedit.edit.kinematics`, with
forward-mode derivatives); the energy is a sum of squares (:mod:`linkedit.edit.objectives`)
minimized by Levenberg–Marquardt (:mod:`linkedit.edit.gauss_newton`) or BFGS, never accepting a
step at which the linkage stops working (:mod:`linkedit.edit.feasibility`).
"""

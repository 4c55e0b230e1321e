"""Function-preserving linkage editing (LinkEdit §4): objectives, singularity barrier, BFGS.

The unknowns are the rest-pose joint positions x̄ (J, 2). The linkage's motion over T motor
angles is a function of x̄ through the reconstruction rules; its derivatives come from the
reverse-mode pass in :mod:`linkedit.edit.adjoint`.
"""

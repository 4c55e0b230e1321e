"""Checked by ``mypy`` in ``make test`` (never run): the notebook API is typed.

``le.simulate`` gives a Motion, ``le.edit`` (the subpackage ``linkedit.edit``, callable) an
Edit, ``le.solve3d`` a Solution: a user's type checker sees these, not ``Any``.
"""

from typing import assert_type

import linkedit as le
from linkedit.notebook import Edit, Motion, Solution


def _check() -> None:
    assert_type(le.simulate("examples/jansen.yaml"), Motion)
    assert_type(le.load("out/jansen.h5"), Motion)
    assert_type(le.edit("examples/jansen.yaml", "examples/edits/jansen-move-knee.yaml"), Edit)
    assert_type(le.solve3d("examples/3d/crank-rocker.yaml"), Solution)

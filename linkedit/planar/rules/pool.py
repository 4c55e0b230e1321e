"""Scratch arrays carved from one flat buffer (:class:`Pool`): the rules' buffers of a
:class:`~linkedit.planar.kinematics.Workspace`."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TypeVar

import numpy as np

T = TypeVar("T")


class Pool:
    """Arrays carved from one flat byte buffer: scratch shared by a plan's rules (they run one
    after another, so each may reuse the same memory), or several arrays kept together. One
    large allocation instead of many: fresh memory pages cost more than the arithmetic on them.
    :meth:`carve` asks a measuring pool first, then one of the size needed."""

    ALIGN = 64  #: bytes: every array starts on a cache line

    def __init__(self, buffer: np.ndarray | None = None) -> None:
        self.buffer = buffer
        self.used = 0
        self.peak = 0

    @classmethod
    def carve(cls, make: Callable[["Pool"], T]) -> T:
        """``make(pool)`` (which asks ``pool`` for its arrays) on a pool just large enough."""
        measure = cls()
        make(measure)
        return make(cls(np.empty(measure.peak, dtype=np.uint8)))

    def reset(self) -> None:
        """Start again from the beginning: later arrays may overlap earlier ones."""
        self.used = 0

    def __call__(self, shape: tuple[int, ...], dtype: type = float) -> np.ndarray:
        """A C-contiguous array of ``shape`` and ``dtype`` (float or complex; uninitialized,
        zero-size while measuring)."""
        start, size = self.used, math.prod(shape) * _ITEMSIZE[dtype]
        self.used = start + -(-size // self.ALIGN) * self.ALIGN
        if self.buffer is None:
            self.peak = max(self.peak, self.used)
            return _EMPTY
        return self.buffer[start:start + size].view(dtype).reshape(shape)


_EMPTY = np.empty(0)
_ITEMSIZE = {float: 8, complex: 16}

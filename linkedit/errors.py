"""The two kinds of failure a user can meet, and their exit codes.

* :class:`InputError` (exit 2): the input is wrong — names the file, the line and the field.
* :class:`MechanismError` (exit 1): the input is valid but the mechanism cannot do what was
  asked — names the joint or constraint and the motor angle.
"""

from __future__ import annotations


class LinkeditError(Exception):
    """Base class of every error linkedit reports to a user (never with a traceback)."""

    exit_code = 1


class InputError(LinkeditError):
    """Bad input: a spec, script, curve file or option that is malformed or inconsistent.

    ``field`` is a path into the document, e.g. ``("links", "upper", 1)``; the loader fills
    ``file`` and ``line`` from it when the error comes out of a validator.
    """

    exit_code = 2

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        line: int | None = None,
        field: tuple[str | int, ...] | str | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.field = tuple(field.split(".")) if isinstance(field, str) else field

    @property
    def field_name(self) -> str:
        """The field path in dotted form, list indices in brackets: ``links.upper[1]``."""
        out = ""
        for part in self.field or ():
            out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
        return out

    def __str__(self) -> str:
        where = self.file or ""
        if self.line is not None:
            where += f":{self.line}"
        head = ": ".join(p for p in (where, self.field_name) if p)
        return f"{head}: {self.message}" if head else self.message


class MechanismError(LinkeditError):
    """A valid mechanism that cannot do what was asked (locks up, complex loop, no solution)."""

    exit_code = 1

"""What every command shares: the error guard and small output helpers."""

from __future__ import annotations

import functools
import json
import math
import sys
from collections.abc import Callable
from typing import Any, TypeVar

import typer

from linkedit.errors import LinkeditError

F = TypeVar("F", bound=Callable[..., Any])


def fail(message: str, code: int) -> typer.Exit:
    """Print ``linkedit: error: message`` on stderr and return the Exit to raise."""
    typer.echo(f"linkedit: error: {message}", err=True)
    return typer.Exit(code)


def guard(fn: F) -> F:
    """Run a command body: user errors become one line on stderr and an exit code, no traceback.

    * :class:`~linkedit.errors.InputError` → 2, :class:`~linkedit.errors.MechanismError` → 1;
    * an unwritable output path (OSError) → 2; Ctrl-C → 130.
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except LinkeditError as exc:
            raise fail(str(exc), exc.exit_code) from None
        except OSError as exc:
            where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
            raise fail(f"{where}{exc.strerror or exc}", 2) from None
        except KeyboardInterrupt:
            raise fail("interrupted", 130) from None

    return wrapper  # type: ignore[return-value]


def print_json(data: Any) -> None:
    """Print ``data`` as JSON on stdout (numpy scalars and arrays converted, NaN/inf as null)."""

    json.dump(_finite(data), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


def _finite(o: Any) -> Any:
    """JSON-ready copy: numpy values as Python ones, NaN/inf as null (JSON has no NaN)."""
    if isinstance(o, dict):
        return {str(k): _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    if hasattr(o, "tolist"):
        return _finite(o.tolist())
    if isinstance(o, float) and not math.isfinite(o):
        return None
    return o

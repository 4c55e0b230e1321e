"""What every command shares: the error guard, one-line usage errors, output-path checks and
small output helpers."""

from __future__ import annotations

import functools
import json
import math
import os
import re
import sys
import warnings
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar

import typer
from typer._click import exceptions as usage  # typer's own copy of click's exceptions
from typer.core import TyperGroup

from linkedit.errors import InputError, LinkeditError

F = TypeVar("F", bound=Callable[..., Any])


def fail(message: str, code: int) -> typer.Exit:
    """Print ``linkedit: error: message`` on stderr and return the Exit to raise."""
    typer.echo(f"linkedit: error: {message}", err=True)
    return typer.Exit(code)


def guard(fn: F) -> F:
    """Run a command body: user errors become one line on stderr and an exit code, no traceback.

    * :class:`~linkedit.errors.InputError` → 2, :class:`~linkedit.errors.MechanismError` → 1;
    * an unwritable output path (OSError) → 2; Ctrl-C or SIGTERM → 130;
    * a closed pipe on stdout (``| head``) → a quiet exit 0.

    The outputs the body writes appear together when it succeeds and not at all when it fails
    (:func:`linkedit.io.atomic.together`); numpy's RuntimeWarnings stay quiet (results are
    checked finite where they are written).
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        from linkedit.io.atomic import terminate_as_interrupt, together

        try:
            with terminate_as_interrupt(), warnings.catch_warnings(), together():
                warnings.simplefilter("ignore", RuntimeWarning)
                try:
                    return fn(*args, **kwargs)
                except typer.Exit as exc:  # an exit code the command chose (a batch where some failed)
                    chosen = exc          # after writing what succeeded: keep that
            raise chosen
        except BrokenPipeError:
            _quiet_stdout()
            raise typer.Exit(0) from None
        except LinkeditError as exc:
            raise fail(str(exc), exc.exit_code) from None
        except OSError as exc:
            where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
            raise fail(f"{where}{exc.strerror or exc}", 2) from None
        except KeyboardInterrupt:
            raise fail("interrupted", 130) from None

    return wrapper  # type: ignore[return-value]


def _quiet_stdout() -> None:
    """After the reader of stdout went away: send the rest (and the final flush) nowhere."""
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout is not a file (tests)
        pass


def check_outputs(outputs: Iterable[tuple[str, Path | None]], inputs: Iterable[Path | str]) -> None:
    """Before anything is written: InputError (exit 2) if an output is an input, two outputs are
    the same file, or an output cannot be written as a regular file (a device node, a folder, a
    read-only folder). ``outputs`` are (option, path) pairs; ``None`` and ``-`` (stdout) are skipped."""
    from linkedit.io.atomic import check_target

    def key(path: Path | str) -> tuple:
        try:
            info = os.stat(path)
            return (info.st_dev, info.st_ino)
        except OSError:
            return (os.path.realpath(path),)

    taken = {key(p): f"the input {p}" for p in inputs}
    for option, path in outputs:
        if path is None or str(path) == "-":  # none, or standard output
            continue
        k = key(path)
        if k in taken:
            raise InputError(f"{path}: would overwrite {taken[k]}", field=option)
        try:
            check_target(path)
        except OSError as exc:
            raise InputError(str(exc), field=option) from None
        taken[k] = f"another output of this run ({option} {path})"


class OneLineErrors(TyperGroup):
    """The command group: usage errors (unknown command or option, bad option value) are one line
    ``linkedit: error: --samples: must be ≥ 8`` with exit 2, like every other input error."""

    def main(self, args: Any = None, prog_name: str | None = None, complete_var: str | None = None,
             standalone_mode: bool = True, **extra: Any) -> Any:
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except usage.NoArgsIsHelpError as exc:
            exc.show()
            code = exc.exit_code
        except usage.ClickException as exc:
            typer.echo(f"linkedit: error: {usage_message(exc)}", err=True)
            code = exc.exit_code
        except typer.Abort:
            typer.echo("linkedit: error: interrupted", err=True)
            code = 130
        if not standalone_mode:
            return code
        sys.exit(code if isinstance(code, int) else 0)


def usage_message(exc: usage.ClickException) -> str:
    """One line for a click usage error: ``--samples: must be ≥ 8``, ``No such option: --x``."""
    param = getattr(exc, "param", None)
    if not isinstance(exc, usage.BadParameter) or isinstance(exc, usage.MissingParameter) \
            or param is None or not param.opts:
        return " ".join(exc.format_message().split())
    name = sorted(param.opts, key=lambda o: (not o.startswith("--"), -len(o)))[0]
    message = " ".join(exc.message.split())
    for words, sign in _BOUNDS:
        message = re.sub(rf"^Input should be {words} (\S+)$", rf"must be {sign} \1", message)
    return f"{name}: {message}"


_BOUNDS = [("greater than or equal to", "≥"), ("less than or equal to", "≤"), ("greater than", ">"),
           ("less than", "<")]


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

"""What every command shares: the error guard, one-line usage errors, output-path checks and
small output helpers."""

from __future__ import annotations

import functools
import json
import math
import os
import re
import signal
import sys
import warnings
from collections.abc import Callable, Iterable, Sequence
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import typer
from typer.core import TyperGroup

from linkedit.errors import InputError, LinkeditError

F = TypeVar("F", bound=Callable[..., Any])


#: the shared ``--json`` and ``--quiet`` options (every command has both; see ``specs/cli-json.md``)
JSON = typer.Option(False, "--json", help="Print one JSON object on stdout (specs/cli-json.md), errors included.")
QUIET = typer.Option(False, "--quiet", "-q", help="Print nothing but errors on stderr (the exit code tells the rest).")


@dataclass
class _Mode:
    json: bool = False
    quiet: bool = False
    command: str = ""
    reported: bool = False


_MODE: ContextVar[_Mode] = ContextVar("linkedit_output_mode", default=_Mode())
#: the running command's name as typed (``simulate``, ``atlas build``), set by :class:`OneLineErrors`
_COMMAND: ContextVar[str] = ContextVar("linkedit_command", default="")

#: click's usage-error classes, reached through typer's public ``BadParameter``: typer ≥ 0.26 runs on
#: its own copy of click (a private module), older typers on click itself, so naming either module
#: ties linkedit to one range of typer versions.
_CLICK_EXCEPTION: Any = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")


def _is(exc: BaseException, name: str) -> bool:
    """Whether ``exc`` is (a subclass of) click's class ``name`` (by name: see ``_CLICK_EXCEPTION``)."""
    return any(c.__name__ == name for c in type(exc).__mro__)


def say(text: str = "", err: bool = False) -> None:
    """A line for a person: on stdout (stderr with ``err``), silent with ``--quiet`` or ``--json``."""
    mode = _MODE.get()
    if not (mode.quiet or (mode.json and not err)):
        typer.echo(text, err=err)


def json_wanted() -> bool:
    """Whether this run prints its JSON report (``--json`` without ``--quiet``)."""
    mode = _MODE.get()
    return mode.json and not mode.quiet


def error_entry(message: str, exit_code: int, *, text: str | None = None, file: str | None = None,
                line: int | None = None, field: str | None = None, source: object = None) -> dict[str, Any]:
    """An error as the JSON report lists it: ``message`` (without the place), ``text`` (the stderr line
    without its ``linkedit: error:`` prefix), ``exit_code``, ``file``, ``line``, ``field``, ``input``."""
    return {"message": message, "text": message if text is None else text, "exit_code": exit_code, "file": file,
            "line": line, "field": field, "input": None if source is None else str(source)}


def error_json(exc: BaseException, source: object = None) -> dict[str, Any]:
    """:func:`error_entry` of a linkedit error (``source``: the batch input it came from)."""
    return error_entry(getattr(exc, "message", None) or str(exc), int(getattr(exc, "exit_code", 1)), text=str(exc),
                       file=getattr(exc, "file", None), line=getattr(exc, "line", None),
                       field=getattr(exc, "field_name", None) or None, source=source)


def report(result: Any, *, exit_code: int = 0, errors: Sequence[dict[str, Any]] = (),
           warnings: Sequence[str] = ()) -> None:
    """Print the run's JSON report on stdout when ``--json`` is given (once per run; see ``specs/cli-json.md``)."""
    mode = _MODE.get()
    if not json_wanted() or mode.reported:
        return
    mode.reported = True
    _print_report(mode.command, result, exit_code, errors, warnings)


def _print_report(command: str, result: Any, exit_code: int, errors: Sequence[dict[str, Any]],
                  warnings: Sequence[str] = ()) -> None:
    from linkedit import __version__

    print_json({"command": command, "linkedit": __version__, "ok": exit_code == 0 and not errors,
                "exit_code": exit_code, "result": result, "errors": list(errors), "warnings": list(warnings)})


def refuse_json_with_stdout(*outputs: Path | str | None) -> None:
    """InputError (exit 2) when ``--json`` and an output on stdout (``-``) would share stdout."""
    if json_wanted() and any(o is not None and str(o) == "-" for o in outputs):
        raise InputError("the JSON report goes to stdout, which an output '-' takes: write that output "
                         "to a file, or drop --json", field="--json")


def fail(message: str, code: int) -> typer.Exit:
    """Print ``linkedit: error: message`` on stderr and return the Exit to raise."""
    typer.echo(f"linkedit: error: {message}", err=True)
    return typer.Exit(code)


def guard(fn: F) -> F:
    """Run a command body: user errors become one line on stderr and an exit code, no traceback.

    * :class:`~linkedit.errors.InputError` → 2, :class:`~linkedit.errors.MechanismError` → 1;
    * an unwritable output path (OSError) → 2; a full disk (ENOSPC, EFBIG) → 1, ``no space left writing
      FILE``; Ctrl-C → 130, SIGTERM → 143 (even when a finalizer
      swallowed the KeyboardInterrupt: :func:`linkedit.io.atomic.check_interrupt`);
    * a closed pipe on stdout (``| head``) → a quiet exit 0;
    * with ``--json`` (a parameter ``as_json``) the error is also the run's JSON report on stdout,
      and ``--quiet`` (``quiet``) silences :func:`say` (see ``specs/cli-json.md``).

    The outputs the body writes appear together when it succeeds and not at all when it fails
    (:func:`linkedit.io.atomic.together`); numpy's RuntimeWarnings stay quiet (results are
    checked finite where they are written).
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        mode = _Mode(json=bool(kwargs.get("as_json")), quiet=bool(kwargs.get("quiet")), command=_COMMAND.get())
        token = _MODE.set(mode)
        try:
            return _run(*args, **kwargs)
        except typer.Exit as exc:
            if exc.exit_code and not mode.reported:  # a failure nobody reported yet (a usage check, a bad file)
                report(None, exit_code=exc.exit_code,
                       errors=[error_entry(f"failed with exit code {exc.exit_code} (see stderr)", exc.exit_code)])
            raise
        finally:
            _MODE.reset(token)

    def _run(*args: Any, **kwargs: Any) -> Any:
        from linkedit.io.atomic import DISK_FULL, check_interrupt, interruptible, together

        try:
            with interruptible(), warnings.catch_warnings(), together():
                warnings.simplefilter("ignore", RuntimeWarning)
                chosen: typer.Exit | None = None
                try:
                    result = fn(*args, **kwargs)
                except typer.Exit as exc:  # an exit code the command chose (a batch where some failed)
                    chosen = exc          # after writing what succeeded: keep that
                check_interrupt()  # a signal whose KeyboardInterrupt a finalizer swallowed
            if chosen is not None:
                raise chosen
            return result
        except BrokenPipeError:
            _quiet_stdout()
            raise typer.Exit(0) from None
        except LinkeditError as exc:
            report(None, exit_code=exc.exit_code, errors=[error_json(exc)])
            raise fail(str(exc), exc.exit_code) from None
        except OSError as exc:
            filename = getattr(exc, "filename", None)
            if exc.errno in DISK_FULL:  # the run was right; the disk could not take its output
                message, code = f"{DISK_FULL[exc.errno]} writing {filename or 'standard output'}", 1
            else:
                message, code = (f"{filename}: " if filename else "") + f"{exc.strerror or exc}", 2
            report(None, exit_code=code, errors=[error_entry(message, code, file=None if filename is None else str(filename))])
            raise fail(message, code) from None
        except KeyboardInterrupt as exc:
            detail = getattr(exc, "detail", "")  # e.g. Dask tasks that did not stop
            raise fail("interrupted" + (f"; {detail}" if detail else ""),
                       128 + getattr(exc, "signum", signal.SIGINT)) from None

    return wrapper  # type: ignore[return-value]


def _quiet_stdout() -> None:
    """After the reader of stdout went away: send the rest (and the final flush) nowhere."""
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout is not a file (tests)
        pass


def check_outputs(outputs: Iterable[tuple[str, Path | None]], inputs: Iterable[Path | str]) -> None:
    """Before anything is written: InputError (exit 2) if an output is an input, lies in a folder given
    as an input (whose files the run reads, and the next run would read it), two outputs are the same
    file, or an output cannot be written as a regular file (a device node, a folder, a read-only
    folder). ``outputs`` are (option, path) pairs; ``None`` and ``-`` (stdout) are skipped; ``inputs``
    are every file and folder the run reads (a curve set's sources included)."""
    from linkedit.io.atomic import check_target

    def key(path: Path | str) -> tuple:
        try:
            info = os.stat(path)
            return (info.st_dev, info.st_ino)
        except OSError:
            return (os.path.realpath(path),)

    inputs = list(inputs)
    taken = {key(p): f"the input {p}" for p in inputs}
    folders = {key(p): p for p in inputs if os.path.isdir(p)}
    for option, path in outputs:
        if path is None or str(path) == "-":  # none, or standard output
            continue
        k = key(path)
        if k in taken:
            raise InputError(f"{path}: would overwrite {taken[k]}", field=option)
        folder = folders.get(key(os.path.dirname(os.path.abspath(path))))
        if folder is not None:
            raise InputError(f"{path}: is in the input folder {folder}, whose files this run reads; "
                             "write it elsewhere", field=option)
        try:
            check_target(path)
        except OSError as exc:
            raise InputError(str(exc), field=option) from None
        taken[k] = f"another output of this run ({option} {path})"


class OneLineErrors(TyperGroup):
    """The command group: usage errors (unknown command or option, bad option value) are one line
    ``linkedit: error: --samples: must be ≥ 1`` with exit 2, like every other input error."""

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None, complete_var: str | None = None,
             standalone_mode: bool = True, windows_expand_args: bool = True, **extra: Any) -> Any:
        words = list(sys.argv[1:] if args is None else args)
        token = _COMMAND.set(self._command_in(words))
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False,
                                windows_expand_args=windows_expand_args, **extra)
        except _CLICK_EXCEPTION as exc:
            if _is(exc, "NoArgsIsHelpError"):  # click ≥ 8.2: a group without its command shows its help
                exc.show()
                code = exc.exit_code
            else:
                message = usage_message(exc)
                typer.echo(f"linkedit: error: {message}", err=True)
                code = exc.exit_code
                if "--json" in words and not {"--quiet", "-q"} & set(words):
                    _print_report(_COMMAND.get(), None, code, [error_entry(message, code)])
        except typer.Abort:
            typer.echo("linkedit: error: interrupted", err=True)
            code = 130
        finally:
            _COMMAND.reset(token)
        if not standalone_mode:
            return code
        sys.exit(code if isinstance(code, int) else 0)


    def _command_in(self, words: Sequence[str]) -> str:
        """The command named in the command line's ``words``: ``simulate``, ``atlas build``."""
        names = [w for w in words if not w.startswith("-")]
        sub = getattr(self.commands.get(names[0]), "commands", None) if names else None  # a group (atlas)
        return " ".join(names[:2] if sub and len(names) > 1 and names[1] in sub else names[:1])


def usage_message(exc: Any) -> str:
    """One line for a click usage error: ``--samples: must be ≥ 1``, ``No such option: --x``."""
    param = getattr(exc, "param", None)
    if not isinstance(exc, typer.BadParameter) or _is(exc, "MissingParameter") or param is None or not param.opts:
        return " ".join(exc.format_message().split())
    name = sorted(param.opts, key=lambda o: (not o.startswith("--"), -len(o)))[0]
    return f"{name}: {_bounds(' '.join(exc.message.split()))}"


def _bounds(message: str) -> str:
    """``must be ≥ 8`` for typer's words of a bound: pydantic's ``Input should be greater than or equal
    to 8`` (typer ≥ 0.26) or click's ``7 is not in the range 8<=x<=4096.`` (older typers)."""
    for words, sign in _WORDS:
        message = re.sub(rf"^Input should be {words} (\S+)$", rf"must be {sign} \1", message)
    m = re.fullmatch(r"\S+ is not in the range (?:(\S+?)(<=|<))?x(?:(<=|<|>=|>)(\S+?))?\.?", message)
    if m:
        sides = ([f"{_SIGN[m[2].replace('<', '>')]} {m[1]}"] if m[1] else []) + ([f"{_SIGN[m[3]]} {m[4]}"] if m[3] else [])
        message = "must be " + " and ".join(sides)
    return message


_WORDS = [("greater than or equal to", "≥"), ("less than or equal to", "≤"), ("greater than", ">"), ("less than", "<")]
_SIGN = {">=": "≥", "<=": "≤", ">": ">", "<": "<"}


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

"""The ``linkedit`` command line: a thin typer shell over the library.

Each command lives in ``linkedit/commands/<name>.py`` with a ``register(app)`` function; this
module only assembles them. Errors are mapped to exit codes in
:func:`linkedit.commands.common.guard`.
"""

from __future__ import annotations

import os

# linkedit's dense linear algebra is small (edit: a few hundred unknowns; 3D steps: tens): BLAS
# threads only spin and contend there, the more so on a busy 2-core machine (a 223×223 Cholesky
# took 175 ms threaded, < 1 ms single). Set before numpy loads; the environment overrides it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import importlib  # noqa: E402

import typer  # noqa: E402

from linkedit import __version__  # noqa: E402
from linkedit.commands.common import OneLineErrors  # noqa: E402

COMMAND_MODULES = [
    "linkedit.commands.simulate",
    "linkedit.commands.assemble",
    "linkedit.commands.import_",
    "linkedit.commands.plot",
    "linkedit.commands.examples",
    "linkedit.commands.edit",
    "linkedit.commands.solve3d",
    "linkedit.commands.curves",
    "linkedit.commands.synthesis",
    "linkedit.commands.bench",
    "linkedit.commands.schemas",
]

app = typer.Typer(
    name="linkedit",
    cls=OneLineErrors,
    help="Design mechanisms: simulate and edit planar linkages, solve 3D mechanisms, compare motion curves.",
    no_args_is_help=True,
    add_completion=True,  # --install-completion / --show-completion for bash, zsh, fish, PowerShell
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help text is plain: "[default: …]" and brackets stay as written
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"linkedit {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", "-V", callback=_version, is_eager=True, help="Print the version."),
) -> None:
    """linkedit: closed-form linkage kinematics, editing, 3D constraint solving, curve features."""


for _name in COMMAND_MODULES:
    try:
        _module = importlib.import_module(_name)
    except ModuleNotFoundError as exc:  # a command whose module is not written yet
        if exc.name != _name:
            raise
        continue
    _module.register(app)


def main() -> None:
    """Console-script entry point."""
    app()

"""``python -m linkedit`` and the ``linkedit`` console script.

Light on purpose: it takes over SIGINT (Ctrl-C) and SIGTERM before the command line imports numpy,
h5py and typer (half a second), so an interrupt at any moment is one line and exit 128 + the
signal (130, 143), never an import's traceback. Until a command's own handling
(:func:`linkedit.io.atomic.interruptible`) starts nothing has been written, so nothing is left to
clean up; once the command has finished, a signal ends the process as it ends any program.

Under a file size limit (``ulimit -f``) Python's byte-code cache is not written: CPython keeps a
``.pyc`` cut short at the limit (its write is not checked), and every later run would fail to import.
"""

import os
import sys

import _signal  # type: ignore[import-not-found]  # the C module, loaded at start-up (`signal` imports enum: 10-30 ms unguarded)

_SIGNALS = (_signal.SIGINT, _signal.SIGTERM)


def _interrupted(signum: int, frame: object) -> None:
    os.write(2, b"linkedit: error: interrupted\n")
    os._exit(128 + signum)


def main() -> None:
    """Console-script entry point: install the signal handling, then import and run the command line."""
    taken = [sig for sig in _SIGNALS if _signal.getsignal(sig) != _signal.SIG_IGN]  # `nohup`, `cmd &`: stay ignored
    for sig in taken:
        _signal.signal(sig, _interrupted)
    import resource

    if resource.getrlimit(resource.RLIMIT_FSIZE)[0] != resource.RLIM_INFINITY:
        sys.dont_write_bytecode = True
    try:
        from linkedit.cli import main as run

        run()
    finally:  # the command is done (its outputs renamed into place): a late signal is no "interrupted"
        for sig in taken:
            _signal.signal(sig, _signal.SIG_DFL)


if __name__ == "__main__":
    main()

"""``python -m linkedit.planar.catalog [DIR]``: rewrite the example files from exact geometry."""

from __future__ import annotations

import argparse
from pathlib import Path

from linkedit.planar.catalog.examples import write_examples


def main(argv: list[str] | None = None) -> None:
    """``python -m linkedit.planar.catalog [DIR]``: rewrite the example files.

    Without DIR it writes into the source checkout's ``examples/`` and refuses when linkedit
    is installed (it never writes into site-packages).
    """
    parser = argparse.ArgumentParser(prog="python -m linkedit.planar.catalog",
                                     description="Write the example linkages (examples/*.yaml) from exact geometry.")
    parser.add_argument("directory", nargs="?", type=Path,
                        help="where to write them [default: examples/ of the source checkout]")
    args = parser.parse_args(argv)
    directory = args.directory
    if directory is None:
        checkout = Path(__file__).resolve().parents[3]
        if not (checkout / "pyproject.toml").is_file() or not (checkout / "examples").is_dir():
            parser.error("not a source checkout: give the folder to write into")
        directory = checkout / "examples"
    for written in write_examples(directory):
        print(written)


if __name__ == "__main__":
    main()

"""``python -m linkedit``: the command line."""

from linkedit.cli import main

main()

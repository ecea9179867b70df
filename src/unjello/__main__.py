"""``python -m unjello``: the command line."""

from .cli import main

main()

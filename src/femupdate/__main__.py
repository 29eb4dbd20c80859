"""``python -m femupdate`` = the ``femupdate`` command."""

from .cli import main

main()

"""``python -m femupdate.cli`` = the ``femupdate`` command."""

from . import main

main()

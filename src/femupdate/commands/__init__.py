"""Sub-commands of ``femupdate`` that live in their own modules.

Every module here is imported by :mod:`femupdate.cli` at start-up and registers its commands on
the :func:`femupdate.cli.cli` group (``from ..cli import cli, json_option, set_option``).  Keep
module-level imports light: heavy libraries are imported inside the command functions.
"""

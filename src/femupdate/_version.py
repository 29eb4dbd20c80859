"""The package version (one place: ``femupdate.__version__`` and the files femupdate writes)."""

__version__ = "0.1.0"

"""The package's version (one place; read by the package, the command and the writers)."""

__version__ = "0.1.0"

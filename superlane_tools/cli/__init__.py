"""The ``slt`` command line: thin Typer apps, one module per command group."""

from superlane_tools.cli.app import app, main

__all__ = ["app", "main"]

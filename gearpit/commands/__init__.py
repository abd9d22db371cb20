"""Subcommands of the ``gearpit`` CLI, one module each."""

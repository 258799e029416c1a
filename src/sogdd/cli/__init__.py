"""The ``sogdd`` command line: one module per sub-command, wired in :mod:`sogdd.cli.main`."""

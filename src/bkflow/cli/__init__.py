"""The ``bkflow`` command line: the parser, the commands (dispatch), the report (all wording),
the guards (process limits, exit codes) and the NAME=VALUE parser."""

from bkflow.cli.commands import main  # noqa: F401

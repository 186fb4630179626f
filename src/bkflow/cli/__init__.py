"""The ``bkflow`` command line: the parser, the commands (dispatch), the report (all wording),
the guards (process limits, exit codes) and the NAME=VALUE parser."""


def main(argv=None) -> int:
    """The ``bkflow`` command (``bkflow.cli.commands.main``), imported only when it runs: a
    program that imports a part of the command line (its NAME=VALUE parser, its report) leaves
    the process as it was (the command sets its thread counts before NumPy loads)."""
    from bkflow.cli.commands import main as command

    return command(argv)

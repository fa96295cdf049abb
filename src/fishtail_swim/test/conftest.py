"""The ``fishtail-swim`` command line, run in-process."""

import pytest


@pytest.fixture
def swim_cli(capsys):
    """Run ``fishtail-swim`` in-process: ``swim_cli(*arguments)`` gives (status, stdout, stderr)."""
    from fishtail_swim.offline.cli import main

    def run(*arguments):
        try:
            status = main([str(argument) for argument in arguments])
        except SystemExit as exit_:
            status = exit_.code
        captured = capsys.readouterr()
        return status, captured.out, captured.err

    return run

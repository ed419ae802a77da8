"""Invoke the ``geoalpha`` command in-process, stdout and stderr kept apart."""

from __future__ import annotations

from click.testing import CliRunner

from geoalpha._cli import main


def run(*args, **kwargs):
    """Invoke the command with ``args`` (made strings); a click ``Result``."""
    try:
        runner = CliRunner(mix_stderr=False)  # click < 8.2
    except TypeError:
        runner = CliRunner()
    return runner.invoke(main, [str(a) for a in args], **kwargs)

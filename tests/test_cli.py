"""The command line as a whole: help for every subcommand, quiet exit on a closed pipe."""
import subprocess
import sys
from pathlib import Path

import pytest

from flexgen.cli import COMMANDS



@pytest.mark.parametrize("command", COMMANDS)
def test_every_subcommand_has_help(command):
    result = subprocess.run([sys.executable, "-m", "flexgen", command, "--help"],
                            capture_output=True, text=True)
    assert result.returncode == 0
    assert f"usage: flexgen {command}" in result.stdout
    assert len(result.stdout.splitlines()) > 4


def test_unknown_subcommand_is_one_line_exit_2():
    result = subprocess.run([sys.executable, "-m", "flexgen", "frobnicate"],
                            capture_output=True, text=True)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr


def test_closed_pipe_is_quiet():
    """`| true` closes the pipe before flexgen writes: no traceback, exit 141 like other tools."""
    result = subprocess.run(
        f"{sys.executable} -m flexgen solve examples/two_link_finger.toml | true; "
        "echo ${PIPESTATUS[0]}", shell=True, executable="/bin/bash", capture_output=True,
        text=True, cwd=Path(__file__).parents[1])
    assert result.stdout.strip() == "141"
    assert "Traceback" not in result.stderr and "BrokenPipe" not in result.stderr

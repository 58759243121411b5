"""``cam-bench`` commands started as a user starts them (a child process each, output to
a log file), and stopped as a user stops them (SIGINT, then a deadline): for the live
tests that run nodes with ``cam-bench run NODE``."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

CLI = 'import sys; from cam_metrology.cli import main; sys.exit(main(sys.argv[1:]))'


def start_cli(args: list[str], log: Path) -> subprocess.Popen[bytes]:
    """``cam-bench ARGS`` in a child process, stdout and stderr to ``log``."""
    handle = open(log, 'wb')  # noqa: SIM115 (closed with the child)
    return subprocess.Popen([sys.executable, '-c', CLI, *args], env=dict(os.environ),
                            stdout=handle, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL)


def stop_cli(children: list[subprocess.Popen[bytes]], timeout: float = 60.0) -> None:
    """SIGINT to every child still running, then wait for each (killed after
    ``timeout`` s)."""
    for child in children:
        if child.poll() is None:
            child.send_signal(2)
    for child in children:
        try:
            child.wait(timeout)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait(10)

"""ROS domain claims (no rclpy needed) and the CLI dispatcher."""
from __future__ import annotations

import subprocess
import sys

import pytest

from cam_metrology.host import isolation
from cam_metrology.cli import main


def test_claim_is_exclusive_across_processes() -> None:
    """A domain held by this process is not handed to another process."""
    mine = isolation.claim_domain()
    assert 1 <= mine <= 100
    assert isolation.claim_domain() == mine   # idempotent
    code = ('from cam_metrology.host import isolation; '
            f'print(isolation.claim_domain(lo={mine}, hi={mine}))')
    proc = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode != 0 and 'no free ROS_DOMAIN_ID' in proc.stderr


def test_isolated_env_is_localhost_only() -> None:
    env = isolation.isolated_env(42, log_dir='/tmp/x')
    assert env['ROS_DOMAIN_ID'] == '42'
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    assert 'ROS_LOCALHOST_ONLY' not in env and env['ROS_LOG_DIR'] == '/tmp/x'


def test_help_lists_commands(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 0
    assert 'COMMAND' in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(['no-such-command'])
    assert exc.value.code == 2


def test_cli_does_not_import_rclpy_for_help() -> None:
    """--help of the whole CLI must not load ROS (fast, works without a ROS graph)."""
    code = ('import sys; from cam_metrology.cli import build_parser; build_parser(); '
            'print("rclpy" in sys.modules)')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         timeout=60)
    assert out.stdout.strip() == 'False', out.stderr


def test_error_prefix_names_the_subcommand(capsys: pytest.CaptureFixture[str]) -> None:
    """QA #25: `design law` errors say `cam-bench design law: error: ...`."""
    assert main(['design', 'law', '/nonexistent/law.yaml']) == 2
    err = capsys.readouterr().err
    assert err.startswith('cam-bench design law: error: ') and 'law.yaml' in err


def test_broken_pipe_is_not_a_traceback(tmp_path) -> None:
    """`cam-bench ... | head -1`: the closed pipe ends the command quietly."""
    import os
    script = ('import sys; from cam_metrology.cli import main; '
              "sys.exit(main(['design', 'law', 'config/default_scene.yaml', '--csv', '-']))")
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    proc = subprocess.Popen([sys.executable, '-c', script], cwd=repo, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.readline()
    proc.stdout.close()       # the reader goes away after one line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 0
    assert 'Traceback' not in err and 'BrokenPipe' not in err

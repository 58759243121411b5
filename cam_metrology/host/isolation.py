"""ROS 2 isolation for tests and one-shot runs: claim a free ROS_DOMAIN_ID.

Domains 1..100 are safe with Fast DDS on this platform (232+ fail, see docs/ros.md).
A domain is claimed by holding an exclusive, non-blocking ``fcntl.flock`` on a lock
file for the lifetime of the process; the lock disappears with the process, so a
crashed run never leaks a claim.
"""
from __future__ import annotations

import fcntl
import os
import tempfile
from pathlib import Path
from typing import IO

_HELD: list[IO[bytes]] = []   # keep the lock files open for the process lifetime


def lock_dir() -> Path:
    """Directory holding the lock files (shared by every process on the machine)."""
    path = Path(tempfile.gettempdir()) / 'cam_bench_ros_domains'
    path.mkdir(parents=True, exist_ok=True)
    return path


def claim_domain(lo: int = 1, hi: int = 100) -> int:
    """Claim and return a free domain id in [lo, hi]; RuntimeError if all are taken.

    Idempotent within a process: a second call returns the domain already held.
    """
    if _HELD:
        return int(Path(_HELD[0].name).stem)
    start = lo + os.getpid() % (hi - lo + 1)   # spread concurrent claimers
    for k in range(hi - lo + 1):
        domain = lo + (start - lo + k) % (hi - lo + 1)
        handle = open(lock_dir() / f'{domain}.lock', 'ab')   # noqa: SIM115 (held open)
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        _HELD.append(handle)
        return domain
    raise RuntimeError(f'no free ROS_DOMAIN_ID in {lo}..{hi}: all are claimed by other runs')


def isolated_env(domain: int, log_dir: str | None = None) -> dict[str, str]:
    """Environment for a child process on ``domain``, localhost discovery only."""
    env = dict(os.environ)
    env['ROS_DOMAIN_ID'] = str(domain)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.pop('ROS_LOCALHOST_ONLY', None)
    env['ROS_LOG_DIR'] = log_dir or env.get('ROS_LOG_DIR') or tempfile.mkdtemp(prefix='ros_log_')
    return env

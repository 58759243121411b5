"""Provenance of a result: which cam-bench, which commit, which input, when, where.

``provenance(bag=..., scene_text=..., params=...)`` returns a JSON-able mapping that
the JSON and HTML reports carry (docs/contract.md §5). The version is
``cam_metrology.__version__`` (kept equal to setup.py and package.xml by a test); the
commit is that of the source tree when it is a git checkout (``null`` otherwise, e.g.
an installed wheel), with ``dirty: true`` when tracked files differ from it.
"""
from __future__ import annotations

import hashlib
import os
import platform
import subprocess
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from cam_metrology import __version__

SOURCE = Path(__file__).resolve().parents[2]


def git_commit(root: Path = SOURCE) -> dict[str, Any]:
    """{commit, dirty} of the git checkout at ``root``; both None if it is not one."""
    if not (root / '.git').exists():
        return {'commit': None, 'dirty': None}
    try:
        env = dict(os.environ, GIT_OPTIONAL_LOCKS='0')
        head = subprocess.run(['git', '-C', str(root), 'rev-parse', 'HEAD'], env=env,
                              capture_output=True, text=True, timeout=10)
        diff = subprocess.run(['git', '-C', str(root), 'status', '--porcelain',
                               '--untracked-files=no'], env=env, capture_output=True,
                              text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return {'commit': None, 'dirty': None}
    if head.returncode != 0:
        return {'commit': None, 'dirty': None}
    return {'commit': head.stdout.strip(),
            'dirty': bool(diff.stdout.strip()) if diff.returncode == 0 else None}


def sha256_path(path: str | Path) -> str:
    """SHA-256 of a file, or of a folder (a bag): its files in name order, each as
    relative path + NUL + content."""
    p = Path(path)
    h = hashlib.sha256()
    files = [p] if p.is_file() else sorted(f for f in p.rglob('*') if f.is_file())
    for f in files:
        if p.is_dir():
            h.update(str(f.relative_to(p)).encode('utf-8') + b'\0')
        with open(f, 'rb') as fh:
            for block in iter(lambda: fh.read(1 << 20), b''):
                h.update(block)
    return h.hexdigest()


def version_text() -> str:
    """``cam-bench 0.1.0 (commit abc1234, modified)`` for ``cam-bench --version``."""
    g = git_commit()
    if g['commit'] is None:
        return f'cam-bench {__version__}'
    return f"cam-bench {__version__} (commit {g['commit'][:12]}" + \
        (', modified)' if g['dirty'] else ')')


def provenance(*, bag: str | Path | None = None, scene_text: str | None = None,
               params: Any = None, command: str | None = None) -> dict[str, Any]:
    """The provenance block of a report (module doc)."""
    out: dict[str, Any] = {'cam_bench_version': __version__, **git_commit(),
                           'time_utc': datetime.now(timezone.utc).isoformat(
                               timespec='seconds'),
                           'host': platform.node(), 'python': platform.python_version()}
    if command is not None:
        out['command'] = command
    if bag is not None:
        out['bag'] = str(Path(bag).resolve())
        out['bag_sha256'] = sha256_path(bag)
    if scene_text is not None:
        out['scene_sha256'] = hashlib.sha256(scene_text.encode('utf-8')).hexdigest()
    if params is not None:
        out['parameters'] = params
    return out

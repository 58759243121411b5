"""A clone of the repository stands alone: nothing a user reads points outside it.

The user-facing text is the README, everything under docs/, config/ and bags/README.md,
every ``--help`` text, and the string literals of the packages (error messages, report
notes, docstrings that ``help()`` shows). None of it may send the reader to files that
are not in the repository (a sibling ``shared`` folder, specification files by their old
names) or to sources by an internal nickname ("seed 004", "the book") instead of the
citation in docs/methods.md.
"""
from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent

#: (pattern, why it is wrong) -- case-insensitive
FORBIDDEN = [
    (r'\.\./shared', 'a folder outside the repository'),
    (r'\bplatform\.md', 'the ROS facts are in docs/ros.md'),
    # a section of the old specification ('methods §5.3', 'methods.md §7 #9')
    (r'\bmethods(\.md)? §', 'cite docs/methods.md or the area doc'),
    (r'\binterfaces\.md', 'the contract is docs/contract.md'),
    (r'\bseeds?[ _-]?00\d', 'cite the source by author (docs/methods.md)'),
    (r'\bthe book\b', 'cite the book as Shang (1988) (docs/methods.md)'),
]


#: outside docs/ a page of docs/ is named with its folder
OUTSIDE_DOCS = [(r'(?<![/\w\[(])methods\.md', 'name it docs/methods.md')]


def _offences(text: str, in_docs: bool = False) -> list[str]:
    found = []
    for pattern, why in FORBIDDEN + ([] if in_docs else OUTSIDE_DOCS):
        for m in re.finditer(pattern, text, flags=re.IGNORECASE):
            line = text.count('\n', 0, m.start()) + 1
            found.append(f'line {line}: {m.group(0)!r} ({why})')
    return found


def _user_files() -> list[Path]:
    files = [REPO / 'README.md', REPO / 'bags' / 'README.md']
    files += sorted((REPO / 'docs').rglob('*.md'))
    files += sorted((REPO / 'config').rglob('*.yaml'))
    return [f for f in files if f.is_file()]


@pytest.mark.parametrize('path', _user_files(), ids=lambda p: str(p.relative_to(REPO)))
def test_user_documents_stand_alone(path: Path) -> None:
    in_docs = path.parent.name == 'docs'
    assert _offences(path.read_text(encoding='utf-8'), in_docs) == []


def _package_sources() -> list[Path]:
    return sorted(p for pkg in ('cam_metrology', 'cam_design') for p in (REPO / pkg).rglob('*.py'))


@pytest.mark.parametrize('path', _package_sources(), ids=lambda p: str(p.relative_to(REPO)))
def test_package_strings_stand_alone(path: Path) -> None:
    """Every string literal (messages, notes, docstrings) of the packages."""
    tree = ast.parse(path.read_text(encoding='utf-8'))
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            bad += [f'{path.name}:{node.lineno}: {o}' for o in _offences(node.value)]
    assert bad == []


def _subcommands() -> list[list[str]]:
    from cam_metrology.cli import build_parser

    parser = build_parser()
    found: list[list[str]] = [[]]

    def walk(p, prefix: list[str]) -> None:
        for action in p._actions:
            choices = getattr(action, 'choices', None)
            if isinstance(choices, dict):
                for name, sub in choices.items():
                    found.append(prefix + [name])
                    walk(sub, prefix + [name])

    walk(parser, [])
    return found


def test_every_help_text_stands_alone() -> None:
    """``cam-bench [SUB ...] --help`` for every subcommand, in one process."""
    from cam_metrology.cli import build_parser

    commands = _subcommands()
    assert len(commands) > 10           # the walk found the subcommand tree
    bad = []
    for cmd in commands:
        parser = build_parser()
        sub = parser
        for name in cmd:
            sub = next(a for a in sub._actions if isinstance(getattr(a, 'choices', None), dict)
                       ).choices[name]
        bad += [f'cam-bench {" ".join(cmd)} --help: {o}' for o in _offences(sub.format_help())]
    assert bad == []


def test_help_runs_as_a_process() -> None:
    """The console entry point answers --help with exit 0 (no ROS import needed)."""
    out = subprocess.run([sys.executable, '-m', 'cam_metrology', '--help'],
                         capture_output=True, text=True, timeout=120, cwd=REPO)
    assert out.returncode == 0, out.stderr
    assert 'cam-bench' in out.stdout and _offences(out.stdout) == []

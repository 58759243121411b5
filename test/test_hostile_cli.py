"""Every subcommand fed hostile inputs: no traceback, ever, and one line naming what.

The scan walks the real parser, so a new subcommand is scanned without editing this
file. Each file argument of each command gets, in turn: binary bytes, a directory, a
missing path, a path through a regular file, an empty file and a file larger than any
input cam-bench reads (sparse); a '-' argument gets binary bytes on standard input.
Outputs of the cheap commands are pointed at a read-only file system, a directory and
a missing folder. Numeric commands run in-process (fast); the live ROS commands run as
subprocesses with a deadline. Expected: exit 2 (refused as bad input) with one line on
stderr naming the command, never a traceback and never the last-resort line
('unexpected error'), which would mean that an input reached code not written for it.
"""
from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from cam_metrology.cli import build_parser, main

REPO = Path(__file__).resolve().parent.parent
CLEAN_BAG = REPO / 'bags' / 'default_clean'
SCENE = REPO / 'config' / 'default_scene.yaml'
LIVE = {'demo', 'record', 'replay', 'run'}
#: above files.MAX_TEXT_BYTES: read whole, it would cost that much memory
HUGE_BYTES = 80 * 1024 * 1024
KINDS = ('binary', 'directory', 'missing', 'through_a_file', 'empty', 'huge')


def leaf_commands() -> list[tuple[list[str], argparse.ArgumentParser]]:
    """(command words, parser) of every subcommand, nested groups included."""
    out = []

    def walk(parser: argparse.ArgumentParser, words: list[str]) -> None:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs:
            out.append((words, parser))
            return
        for name, sub in subs[0].choices.items():
            walk(sub, words + [name])
    walk(build_parser(), [])
    return out


#: options that name a file to read, scanned wherever a command has them
INPUT_OPTIONS = ('--scene', '--params', '--measured', '--spec')


def file_arguments(parser: argparse.ArgumentParser) -> tuple[list[Any], list[Any]]:
    """(positional arguments, required options and file-reading options) of a
    subcommand parser."""
    positional = [a for a in parser._actions if not a.option_strings and not a.choices]
    options = [a for a in parser._actions if a.option_strings and (
        a.required or set(a.option_strings) & set(INPUT_OPTIONS))]
    return positional, options


@pytest.fixture(scope='module')
def hostile(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp('hostile')
    rng = __import__('random').Random(23)
    (root / 'binary.yaml').write_bytes(bytes(rng.randrange(256) for _ in range(4096)))
    (root / 'adir').mkdir()
    (root / 'afile').write_text('x')
    (root / 'empty.yaml').write_bytes(b'')
    with open(root / 'huge.yaml', 'wb') as f:   # sparse: no disk space used
        f.truncate(HUGE_BYTES)
    return {'binary': root / 'binary.yaml', 'directory': root / 'adir',
            'missing': root / 'missing.yaml', 'through_a_file': root / 'afile' / 'x.yaml',
            'empty': root / 'empty.yaml', 'huge': root / 'huge.yaml', 'root': root}


def _fill(parser: argparse.ArgumentParser, words: list[str], target: Any, value: str,
          scratch: Path) -> list[str]:
    """argv with ``value`` for the argument ``target`` and harmless values elsewhere."""
    positional, options = file_arguments(parser)
    argv = list(words)
    for action in positional:
        if action is target:
            argv.append(value)
        elif action.dest == 'bag':   # a valid bag, so that an option is read after it
            argv.append(str(CLEAN_BAG))
        else:   # other positionals: a new output path (OUT of simulate, golden ...)
            argv.append(str(scratch / f'other_{action.dest}'))
    for action in options:
        if action is target:
            argv += [action.option_strings[0], value]
        elif action.required and action.type in (int, float):   # a number: a harmless one
            argv += [action.option_strings[0], '1000']
        elif action.required:
            argv += [action.option_strings[0], str(scratch / f'opt_{action.dest}')]
    if words == ['design', 'rocker']:
        argv = list(words) + ['--arm-length', '0.04', '--base-radius', '0.015',
                              '--max-swing-deg', '20']
    return argv


def _assert_refused(words: list[str], code: int, err: str, argv: list[str]) -> None:
    assert 'Traceback' not in err, (argv, err)
    err = err.split('\n--- stdout ---\n')[0]
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines, (argv, code)
    assert lines[-1].startswith(f'cam-bench {" ".join(words)}'), (argv, err)
    assert 'unexpected error' not in lines[-1], (argv, err)
    assert code == 2, (argv, code, err)


def _run_in_process(argv: list[str], capsys: pytest.CaptureFixture[str],
                    stdin: bytes | None = None) -> tuple[int, str]:
    """Exit code and stderr (stdout, if any, appended after a marker line)."""
    old = sys.stdin
    if stdin is not None:
        sys.stdin = io.TextIOWrapper(io.BytesIO(stdin), encoding='utf-8')
    try:
        code = main(argv)
    finally:
        sys.stdin = old
    captured = capsys.readouterr()
    return code, captured.err + ('\n--- stdout ---\n' + captured.out if captured.out else '')


def file_inputs(parser: argparse.ArgumentParser) -> list[Any]:
    """The arguments of a subcommand that name a file or folder to read."""
    positional, options = file_arguments(parser)
    return [a for a in positional + options if a.type in (None, str)   # not numbers
            and not (a.dest in ('out', 'dst') or a.option_strings == ['--out'])]


NUMERIC = [(w, p) for w, p in leaf_commands() if w[0] not in LIVE and file_inputs(p)]


@pytest.mark.parametrize('kind', KINDS)
@pytest.mark.parametrize('words', [w for w, _ in NUMERIC], ids=' '.join)
def test_every_input_argument_refuses_hostile_files(words: list[str], kind: str,
                                                    hostile: dict[str, Path], tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str],
                                                    ) -> None:
    parser = dict((tuple(w), p) for w, p in NUMERIC)[tuple(words)]
    for target in file_inputs(parser):
        argv = _fill(parser, words, target, str(hostile[kind]), tmp_path)
        code, err = _run_in_process(argv, capsys)
        if words == ['batch'] and code == 1:   # a bad bag: a failed row of the table
            assert 'Traceback' not in err and '1 failed' in err, (argv, err)
            continue
        _assert_refused(words, code, err, argv)
        leftovers = [p.name for p in tmp_path.iterdir()]
        assert leftovers == [], (argv, leftovers)


STDIN = [w for w, p in NUMERIC if any(a.dest in ('file', 'input', 'table', 'spec')
                                      for a in file_arguments(p)[0])]


@pytest.mark.parametrize('words', STDIN, ids=' '.join)
def test_binary_standard_input_is_refused(words: list[str], tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    parser = dict((tuple(w), p) for w, p in NUMERIC)[tuple(words)]
    target = file_arguments(parser)[0][0]
    argv = _fill(parser, words, target, '-', tmp_path)
    code, err = _run_in_process(argv, capsys, stdin=b'\xff\xfe\x00\x81\x00binary')
    _assert_refused(words, code, err, argv)


#: cheap runs with a valid input, and the output options to point at a bad place
OUTPUTS = [
    (['analyze', str(CLEAN_BAG), '--only-metrology'],
     ['--json', '--csv', '--report', '--plot', '--out-bag']),
    (['simulate', '--samples-per-rev', '360', '--quiet'], ['OUT']),
    (['bag', 'recover', str(CLEAN_BAG)], ['DST']),
    (['golden', str(CLEAN_BAG)], ['OUT']),
    (['design', 'law', str(SCENE), '--lobe', 'lobe_1'], ['--json', '--csv', '--nominal']),
    (['design', 'rocker', '--arm-length', '0.04', '--base-radius', '0.015',
      '--max-swing-deg', '20'], ['--json']),
]


@pytest.mark.parametrize('place', ['read_only', 'directory', 'missing_folder'])
@pytest.mark.parametrize('argv, options', OUTPUTS,
                         ids=['analyze', 'simulate', 'bag recover', 'golden', 'design law',
                              'design rocker'])
def test_outputs_in_a_bad_place_are_one_line(argv: list[str], options: list[str],
                                             place: str, tmp_path: Path, small_disk: Any,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    if place == 'read_only':
        folder = small_disk(64, read_only=True)
        target = folder / 'out'
    elif place == 'directory':
        target = tmp_path / 'adir'
        target.mkdir()
        (target / 'keep').write_text('kept')
    else:
        target = tmp_path / 'no_such_folder' / 'out'
    words = [w for w in argv[:2] if not w.startswith(('-', '/')) and '/' not in w]
    for option in options:
        if option == '--plot' and place != 'read_only':
            continue   # a folder, created when missing: not a bad place
        full = argv + ([str(target)] if option.isupper() else [option, str(target)])
        code, err = _run_in_process(full, capsys)
        _assert_refused(words[:2] if words[:1] in (['bag'], ['design']) else words[:1],
                        code, err, full)
        line = err.split('\n--- stdout ---\n')[0].strip().splitlines()[-1]
        assert str(target) in line, line
        if place == 'directory':
            assert (target / 'keep').read_text() == 'kept'
            assert [p.name for p in target.iterdir()] == ['keep']
        else:
            assert not target.exists()


LIVE_CASES = [
    ['replay', 'binary'], ['replay', 'directory'], ['replay', 'missing'],
    ['run', 'metrology', '--params', 'binary'], ['run', 'recorder', '--params', 'huge'],
]


@pytest.mark.ros
@pytest.mark.parametrize('case', LIVE_CASES, ids=' '.join)
def test_live_commands_refuse_hostile_files(case: list[str], hostile: dict[str, Path],
                                            ros_domain: int) -> None:
    argv = [str(hostile[w]) if w in hostile else w for w in case]
    proc = subprocess.run([sys.executable, '-m', 'cam_metrology', *argv], cwd=REPO,
                          capture_output=True, text=True, timeout=120,
                          env=dict(os.environ))
    _assert_refused(case[:1], proc.returncode, proc.stderr, argv)


def test_unexpected_error_is_one_line_and_debug_shows_the_traceback(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """The last resort: a bug (simulated) is one line naming the command and the input,
    exit 1; --debug or CAM_BENCH_DEBUG=1 adds the traceback."""
    import cam_metrology.cli.scene.check as scene_check

    def broken(_path: str) -> Any:
        raise ZeroDivisionError('division by zero (a simulated bug)')

    monkeypatch.setattr(scene_check, 'load_scene_arg', broken)
    assert main(['scene', 'check', 'some.yaml']) == 1
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'Traceback' not in err
    assert err.startswith("cam-bench scene check: unexpected error on 'some.yaml': "
                          'ZeroDivisionError: division by zero (a simulated bug)')
    assert '--debug' in err
    assert main(['--debug', 'scene', 'check', 'some.yaml']) == 1
    assert 'Traceback (most recent call last)' in capsys.readouterr().err
    monkeypatch.setenv('CAM_BENCH_DEBUG', '1')
    assert main(['scene', 'check', 'some.yaml']) == 1
    assert 'Traceback (most recent call last)' in capsys.readouterr().err


def test_unexpected_error_names_the_input_files_not_every_option(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """The one line of a bug names the files the command read (a value such as 0.5 or
    1e-3 is not a file; an ``--option=FILE`` is), not the whole argument string; with no
    file among them it gives the arguments as typed."""
    import cam_metrology.cli.card as card

    def broken(_args: Any) -> int:
        raise ZeroDivisionError('division by zero (a simulated bug)')

    monkeypatch.setattr(card, 'run', broken)
    assert main(['card', 'lobe.csv', '--heights-mm', '0.5,1e-3', '--json=out.json',
                 '--lobe', 'in1']) == 1
    err = capsys.readouterr().err
    assert err.startswith("cam-bench card: unexpected error on 'lobe.csv', 'out.json': "
                          'ZeroDivisionError'), err
    assert '--heights-mm' not in err and 'in1' not in err
    assert main(['card', 'nothing', '--lobe', 'in1']) == 1
    assert "unexpected error on 'nothing --lobe in1': " in capsys.readouterr().err


@pytest.mark.skipif(not Path('/dev/full').exists(), reason='no /dev/full on this system')
def test_standard_output_on_a_full_disk_is_one_line() -> None:
    """`> /dev/full`: every write fails with ENOSPC. The printed result cannot be
    delivered: exit 2 naming stdout and the reason, not a success and not a traceback."""
    with open('/dev/full', 'w') as full:
        proc = subprocess.run([sys.executable, '-m', 'cam_metrology', 'scene', 'check',
                               str(SCENE)], cwd=REPO, stdout=full, stderr=subprocess.PIPE,
                              text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == ("cam-bench scene check: error: stdout: got '-'; expected "
                                   'a writable standard output (the disk is full)')

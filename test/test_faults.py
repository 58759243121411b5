"""Faults a bench meets: hostile YAML, a full or read-only disk, outputs in the way,
names from input used as file names, Ctrl-C in the middle of a run.

Each class has one promise (docs/reliability.md): one line naming the option or key,
exit 2, and no output file that looks complete but is not.
"""
from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cam_design.errors import InputError
from cam_metrology.inputs.files import atomic_dir, safe_name, write_output
from cam_metrology.inputs.yaml_input import load_yaml

REPO = Path(__file__).resolve().parent.parent
CLI = [sys.executable, '-m', 'cam_metrology']

#: nine levels of nine aliases: 9^9 = 387 million leaves from 500 bytes
BOMB = 'a: &a ["x","x","x","x","x","x","x","x","x"]\n' + ''.join(
    f'{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n'
    for p, c in zip('abcdefgh', 'bcdefghi'))


def _cli(*args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=timeout,
                          cwd=REPO)


def _one_line_error(proc: subprocess.CompletedProcess[str], *words: str) -> str:
    assert proc.returncode == 2, proc.stderr
    assert 'Traceback' not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


# ------------------------------------------------------------------------ YAML bombs
def test_bomb_refused_before_expansion() -> None:
    assert len(BOMB) < 600
    with pytest.raises(InputError) as err:
        load_yaml(BOMB, 'scene')
    assert err.value.key == 'scene' and 'alias' in str(err.value)


def test_aliases_of_normal_size_still_load() -> None:
    doc = load_yaml('base: &b {k: 1}\nx: *b\ny: [*b, *b]\n', 'scene')
    assert doc['y'][1] == {'k': 1}


def test_oversized_text_refused_by_size() -> None:
    with pytest.raises(InputError, match='at most 100 characters'):
        load_yaml('a: 1\n' * 50, 'k', max_chars=100)


@pytest.mark.parametrize('command', [
    ['scene', 'check'], ['analyze', 'bags/default_clean', '--params']])
def test_bomb_file_is_one_line_exit_2(tmp_path: Path, command: list[str]) -> None:
    bomb = tmp_path / 'bomb.yaml'
    bomb.write_text(BOMB)
    proc = _cli(*command, str(bomb), timeout=30)
    _one_line_error(proc, 'alias')


def test_bomb_scene_inside_a_bag_is_refused(tmp_path: Path) -> None:
    from cam_metrology.bagio import BagWriter, copy_bag, encode_string

    bag = tmp_path / 'bombed'
    with BagWriter(bag) as w:
        copy_bag(REPO / 'bags' / 'default_clean', w, ['/bench/joint_states'])
        w.add_topic('/bench/scene', 'std_msgs/msg/String')
        w.write('/bench/scene', 1, encode_string(BOMB))
    proc = _cli('analyze', str(bag), timeout=30)
    _one_line_error(proc, '/bench/scene', 'alias')


def test_bomb_in_bag_metadata_is_refused(tmp_path: Path) -> None:
    import shutil

    bag = tmp_path / 'meta'
    shutil.copytree(REPO / 'bags' / 'default_clean', bag)
    (bag / 'metadata.yaml').write_text(BOMB)
    proc = _cli('bag', 'info', str(bag), timeout=30)   # refused at once, not expanded
    _one_line_error(proc, str(bag), 'rosbag2')


# ------------------------------------------------------------- writing outputs safely
def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if 'partial' in p.name)


@pytest.mark.parametrize('code, reason, where', [
    (errno.ENOSPC, 'the disk is full', 'fsync'),
    (errno.EROFS, 'a read-only file system', 'replace'),
    (errno.EACCES, 'permission denied', 'replace'),
])
def test_failed_write_names_option_path_reason_and_leaves_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, code: int, reason: str,
        where: str) -> None:
    def fail(*_a: object) -> None:
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr(os, where, fail)
    target = tmp_path / 'report.json'
    with pytest.raises(InputError) as err:
        write_output(target, '{"a": 1}', '--json')
    assert err.value.key == '--json' and str(target) in str(err.value)
    assert reason in str(err.value)
    assert not target.exists() and _leftovers(tmp_path) == []


def test_failed_write_keeps_the_previous_file_whole(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / 'report.json'
    target.write_text('old complete report')

    def full(*_a: object) -> None:
        raise OSError(errno.ENOSPC, 'No space left on device')

    monkeypatch.setattr(os, 'fsync', full)
    with pytest.raises(InputError):
        write_output(target, 'new report that does not fit', '--json')
    assert target.read_text() == 'old complete report'


def test_output_that_is_a_directory_is_refused_by_the_cli(tmp_path: Path) -> None:
    proc = _cli('analyze', 'bags/default_clean', '--json', str(tmp_path))
    _one_line_error(proc, '--json', str(tmp_path), 'not a directory')


def test_output_bag_that_exists_is_never_overwritten(tmp_path: Path) -> None:
    out = tmp_path / 'out'
    out.mkdir()
    (out / 'keep.txt').write_text('x')
    proc = _cli('simulate', str(out), '--quiet')
    _one_line_error(proc, 'OUT_BAG', 'never overwritten')
    assert (out / 'keep.txt').read_text() == 'x'


def test_atomic_dir_removes_everything_on_error(tmp_path: Path) -> None:
    target = tmp_path / 'bag'
    with pytest.raises(RuntimeError):
        with atomic_dir(target, 'OUT') as tmp:
            tmp.mkdir()
            (tmp / 'half.mcap').write_bytes(b'\0' * 100)
            raise RuntimeError('boom')
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------- names derived from input
@pytest.mark.parametrize('text, expected', [
    ('../x', '_x'), ('..', '_'), ('.', '_'), ('', '_'), ('a/b\\c', 'a_b_c'),
    ('lobe 1:in', 'lobe_1_in'), ('/etc/passwd', '_etc_passwd'), ('ok-1.2_x', 'ok-1.2_x'),
])
def test_safe_name(text: str, expected: str) -> None:
    assert safe_name(text) == expected


def test_plot_of_feature_named_dot_dot_stays_in_plot_dir(tmp_path: Path) -> None:
    scene = (REPO / 'config' / 'default_scene.yaml').read_text()
    scene = scene.replace('- id: lobe_1 ', "- id: '../escape' ", 1)
    assert '../escape' in scene
    (tmp_path / 'scene.yaml').write_text(scene)
    bag = tmp_path / 'bag'
    assert _cli('simulate', str(bag), '--scene', str(tmp_path / 'scene.yaml'),
                '--samples-per-rev', '720', '--quiet').returncode == 0
    plots = tmp_path / 'plots'
    proc = _cli('analyze', str(bag), '--plot', str(plots), '--only-metrology')
    assert proc.returncode == 0, proc.stderr
    outside = [p for p in tmp_path.iterdir() if p.name not in ('scene.yaml', 'bag', 'plots')]
    assert outside == []
    assert any('escape' in p.name for p in plots.iterdir())


# ------------------------------------------------------------------- options named
def test_huge_samples_per_rev_is_blamed_on_that_option(tmp_path: Path) -> None:
    proc = _cli('simulate', str(tmp_path / 'b'), '--samples-per-rev', '100000000')
    _one_line_error(proc, '--samples-per-rev', '100000000')


def test_huge_revolutions_is_blamed_on_that_option(tmp_path: Path) -> None:
    proc = _cli('simulate', str(tmp_path / 'b'), '--revolutions', '100000')
    _one_line_error(proc, '--revolutions')


# ------------------------------------------------------------------------- Ctrl-C
def test_ctrl_c_during_simulate_leaves_no_bag(tmp_path: Path) -> None:
    out = tmp_path / 'long'
    proc = subprocess.Popen([*CLI, 'simulate', str(out), '--revolutions', '400'],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=REPO)
    deadline = time.monotonic() + 60
    holder = None
    while time.monotonic() < deadline and holder is None:   # wait until it is writing
        holder = next((p for p in tmp_path.iterdir() if 'partial' in p.name), None)
        if proc.poll() is not None:
            break
        time.sleep(0.02)
    assert holder is not None and proc.poll() is None, 'simulate finished too soon'
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    # 130, or death by SIGINT (-2), which a shell also reports as 130
    assert proc.returncode in (130, -signal.SIGINT), (proc.returncode, out[-2000:],
                                                      err[-2000:])
    assert 'Traceback' not in err
    assert list(tmp_path.iterdir()) == []

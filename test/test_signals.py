"""SIGINT and SIGTERM at several moments of `simulate`, `analyze --out-bag`, `batch`
and `record`: the documented exit code (130, 143; `record`: 0, its normal stop) and one
line saying what was kept, never a traceback, never a half-written output.

Each run is a subprocess; the signal is sent when the run reaches a point seen from
outside (a progress line, a temporary file appearing or growing), each wait with a
deadline, never a fixed sleep.
"""
from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable

import pytest

REPO = Path(__file__).resolve().parent.parent
CLI = [sys.executable, '-m', 'cam_metrology']
CODE = {signal.SIGINT: 130, signal.SIGTERM: 143}


class Run:
    """A `cam-bench` subprocess whose stderr lines are collected as they come."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen([*CLI, *args], stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True, cwd=REPO,
                                     env=dict(os.environ, OPENBLAS_NUM_THREADS='1'))
        self.lines: queue.Queue[str] = queue.Queue()
        self.err: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.lines.put(line)

    def wait_for(self, ready: Callable[[], bool], what: str, timeout: float = 120) -> None:
        """Until ``ready()`` (or a stderr line arrives that makes it so); fails if the
        run ended first or the deadline passed."""
        deadline = time.monotonic() + timeout
        while not ready():
            assert self.proc.poll() is None, f'ended before {what}: {"".join(self.err)}'
            assert time.monotonic() < deadline, f'no {what} within {timeout} s'
            try:
                self.err.append(self.lines.get(timeout=0.02))
            except queue.Empty:
                pass

    def said(self, text: str) -> Callable[[], bool]:
        return lambda: any(text in ln for ln in self.err)

    def stop(self, sig: signal.Signals, timeout: float = 120) -> tuple[int, str, str]:
        self.proc.send_signal(sig)
        try:
            self.proc.wait(timeout=timeout)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
        self.reader.join(timeout=30)   # stderr closed: every line is in the queue
        while not self.lines.empty():
            self.err.append(self.lines.get())
        assert self.proc.stdout is not None
        return self.proc.returncode, self.proc.stdout.read(), ''.join(self.err)


def _interrupted_line(err: str, command: str, sig: signal.Signals) -> str:
    assert 'Traceback' not in err, err
    line = [ln for ln in err.splitlines() if ln.strip()][-1]
    assert line.startswith(f'cam-bench {command}: interrupted by {sig.name}: '), err
    return line


def _partial(folder: Path) -> list[Path]:
    return [p for p in folder.iterdir() if 'partial' in p.name]


def _size(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob('*') if p.is_file())


# --------------------------------------------------------------------------- simulate
@pytest.mark.slow
@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=lambda s: s.name)
@pytest.mark.parametrize('point', ['holder made', '25 %', '80 %'])
def test_simulate_interrupted_leaves_nothing(tmp_path: Path, sig: signal.Signals,
                                             point: str) -> None:
    out = tmp_path / 'long'
    run = Run('simulate', str(out), '--revolutions', '60', '--samples-per-rev', '3600')
    if point == 'holder made':
        run.wait_for(lambda: bool(_partial(tmp_path)), 'temporary bag folder')
    else:
        run.wait_for(run.said(f'({point})'), f'progress {point}')
    code, _, err = run.stop(sig)
    assert code == CODE[sig], (code, err)
    line = _interrupted_line(err, 'simulate', sig)
    assert f'OUT_BAG {out} not written' in line, line
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------- analyze --out-bag
@pytest.fixture(scope='module')
def long_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    bag = tmp_path_factory.mktemp('long') / 'bag'
    proc = subprocess.run([*CLI, 'simulate', str(bag), '--revolutions', '20', '--quiet',
                           '--noise-um', '0.5'], cwd=REPO, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    return bag


@pytest.mark.slow
@pytest.mark.parametrize('sig, point', [(signal.SIGINT, 'started'),
                                        (signal.SIGTERM, 'started'),
                                        (signal.SIGTERM, 'a third written')],
                         ids=['SIGINT-started', 'SIGTERM-started', 'SIGTERM-third'])
def test_analyze_out_bag_interrupted_leaves_no_bag(long_bag: Path, tmp_path: Path,
                                                   sig: signal.Signals, point: str) -> None:
    out = tmp_path / 'regenerated'
    run = Run('analyze', str(long_bag), '--out-bag', str(out), '--only-metrology',
              '--json', str(tmp_path / 'r.json'))
    if point == 'started':
        run.wait_for(lambda: bool(_partial(tmp_path)), 'temporary --out-bag folder')
    else:
        third = _size(long_bag) / 3
        run.wait_for(lambda: bool(_partial(tmp_path)) and _size(tmp_path) > third,
                     'a third of the bag written')
    code, _, err = run.stop(sig)
    assert code == CODE[sig], (code, err)
    line = _interrupted_line(err, 'analyze', sig)
    assert f'--out-bag {out} not written' in line, line
    assert list(tmp_path.iterdir()) == []   # no bag, no half report


# ------------------------------------------------------------------------------ batch
@pytest.fixture(scope='module')
def archive(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Twelve distinct small bags (copies of one, each with another metadata comment)."""
    import shutil

    root = tmp_path_factory.mktemp('archive')
    first = root / 'b00'
    proc = subprocess.run([*CLI, 'simulate', str(first), '--samples-per-rev', '360',
                           '--quiet', '--scene', str(REPO / 'bags' / 'scenes' /
                                                     'two_lobes_no_pin.yaml')],
                          cwd=REPO, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    bags = [first]
    for i in range(1, 12):
        bag = root / f'b{i:02d}'
        shutil.copytree(first, bag)
        with open(bag / 'metadata.yaml', 'a', encoding='utf-8') as f:
            f.write(f'# copy {i}\n')
        bags.append(bag)
    return bags


@pytest.mark.slow
def test_batch_interrupted_before_any_bag_keeps_the_table_as_it_was(
        archive: list[Path], tmp_path: Path) -> None:
    out = tmp_path / 'r.parquet'
    run = Run('batch', *map(str, archive), '--out', str(out), '--workers', '1')
    run.wait_for(run.said('cam-bench batch: 12 bags'), 'the bag count')
    code, _, err = run.stop(signal.SIGINT)
    assert code == 130, (code, err)
    _interrupted_line(err, 'batch', signal.SIGINT)
    assert not out.exists() and _partial(tmp_path) == []


@pytest.mark.slow
def test_batch_interrupted_midway_keeps_the_bags_done_and_resumes(
        archive: list[Path], tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    out = tmp_path / 'r.parquet'
    run = Run('batch', *map(str, archive), '--out', str(out), '--workers', '1')
    run.wait_for(run.said('[3/12]'), 'three bags analysed', timeout=300)
    code, _, err = run.stop(signal.SIGTERM)
    assert code == 143, (code, err)
    line = _interrupted_line(err, 'batch', signal.SIGTERM)
    kept = {r['bag'] for r in pq.read_table(out).to_pylist()}
    assert 3 <= len(kept) < 12, line
    assert f'{len(kept)} of 12 bags analysed before the signal are in {out}' in line, line
    again = subprocess.run([*CLI, 'batch', *map(str, archive), '--out', str(out),
                            '--workers', '1'], cwd=REPO, capture_output=True, text=True,
                           timeout=600)
    assert again.returncode == 0, again.stderr
    assert f'{12 - len(kept)} analysed, {len(kept)} already in' in again.stdout
    rows = pq.read_table(out).to_pylist()
    assert {r['bag'] for r in rows} == set(map(str, archive))
    assert all(r['status'] == 'ok' for r in rows)


# ----------------------------------------------------------- a signal after the run
def test_signal_after_the_run_is_reported_not_lost() -> None:
    """A signal that arrives once the outputs are complete (blocked, pending) is still
    seen: the run is reported as interrupted, with the note that it had completed."""
    from cam_metrology.host.interrupts import COMPLETE, exit_code, settle_signals

    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    try:
        signal.raise_signal(signal.SIGTERM)   # pending: blocked
        late = settle_signals()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
    assert late is not None and late.args[0] == 'SIGTERM'
    assert late.__notes__ == [COMPLETE]
    assert signal.SIGTERM not in signal.sigpending()   # consumed, not raised later
    assert (exit_code('SIGINT'), exit_code('SIGTERM')) == (130, 143)
    assert settle_signals() is None

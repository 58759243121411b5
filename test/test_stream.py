"""Streamed reading of bags: blocks of samples equal the whole-bag read, reports equal
the whole-bag analysis, and the peak memory of an analysis does not grow with a bag
of repeated measurements (docs/contract.md §4, docs/limits.md)."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology import bagio
from cam_metrology.metrology.core import MetrologyCore
from cam_metrology.host.paths import default_scene_path
from cam_metrology.offline.replay import run_offline
from cam_metrology.scene.parse import load_scene
from cam_metrology.simulation.bench import SimParams, write_sim_bag

REPO = Path(__file__).resolve().parent.parent
BAGS = sorted(p.parent for p in (REPO / 'bags').glob('*/metadata.yaml'))
JS = bagio.JOINT_STATES


def _same_samples(blocks: list[bagio.JointSamples], whole: bagio.JointSamples) -> None:
    """The concatenated blocks hold the whole read's samples, in its order."""
    assert sum(len(b) for b in blocks) == len(whole)
    if not len(whole):
        return
    cat = {f: np.concatenate([getattr(b, f) for b in blocks])
           for f in ('stamp_ns', 'log_ns', 'theta', 's')}
    np.testing.assert_array_equal(cat['stamp_ns'], whole.stamp_ns)
    np.testing.assert_array_equal(cat['log_ns'], whole.log_ns)
    # decoded from the same bytes: equal to the last bit, compared with a stated 0 tolerance
    np.testing.assert_allclose(cat['theta'], whole.theta, rtol=0, atol=0)
    np.testing.assert_allclose(cat['s'], whole.s, rtol=0, atol=0)
    ids = np.concatenate([b.frame_id.astype(str) for b in blocks])
    assert ids.tolist() == whole.frame_id.astype(str).tolist()


def _summary(blocks: list[bagio.JointSamples]) -> bagio.JointSummary:
    out = bagio.JointSummary()
    for b in blocks:
        out.add(b)
    return out


@pytest.mark.parametrize('bag', BAGS, ids=[b.name for b in BAGS])
@pytest.mark.parametrize('direct, block', [(True, 1), (True, 1 << 30), (False, 2000)])
def test_blocks_of_a_fixture_equal_the_whole_read(bag, direct, block):
    whole = bagio.read_joint_states(bag, direct=direct)
    blocks = list(bagio.iter_joint_states(bag, direct=direct, block_bytes=block))
    if block == 1:   # one MCAP chunk a block: the fixtures have more than one
        assert len(blocks) >= 2 or bag.name == 'no_pin_no_valve_train'
    _same_samples(blocks, whole)
    summary = _summary(blocks)
    assert (summary.count, summary.names, summary.features, summary.issues) == \
        (len(whole), whole.names, whole.features, whole.issues)


def _irregular_bag(path: Path, n: int = 12_000) -> None:
    """JointStates over several MCAP chunks (about 1 MB each), written out of log-time
    order so that chunks overlap in time, with messages lacking a joint or positions in
    different chunks, and other joint orders."""
    t0 = 1_000_000_000
    kinds = []
    with bagio.BagWriter(path) as w:
        w.write('/bench/scene', t0, bagio.encode_string('scene'))
        for k in range(n):
            # even k: early half of the time line; odd k: interleaved later, so the
            # second half of the file goes back in time
            log = t0 + 10 * (k // 2 if k < n // 2 else (k - n // 2) // 2) + 1 + (k % 2) * 5
            if k == n // 3:
                names, pos = ('probe', 'other'), (1.0, 2.0)          # no camshaft
            elif k in (n // 2 + 7, n - 3):
                names, pos = ('camshaft', 'x'), (0.1, 0.2)           # no probe
            elif k == 2 * n // 3:
                names, pos = ('camshaft', 'probe'), (0.3,)           # too few positions
            elif k % 5 == 0:
                names, pos = ('probe', 'camshaft'), (1e-3 * k, 0.001 * k)
            else:
                names, pos = ('camshaft', 'probe'), (0.001 * k, 1e-3 * k)
            kinds.append(names)
            fid = f'lobe_{1 + (k // 3000)}'
            w.write(JS, log, bagio.encode_joint_state_positions(fid, log - 3, names, pos))


def test_overlapping_chunks_and_issues_are_merged_exactly(tmp_path):
    bag = tmp_path / 'bag'
    _irregular_bag(bag)
    whole = bagio.read_joint_states(bag)
    assert np.all(np.diff(whole.log_ns) >= 0)
    assert [i.count for i in whole.issues] == [1, 2, 1]
    for block in (1, 200_000, 1 << 30):
        blocks = list(bagio.iter_joint_states(bag, block_bytes=block))
        _same_samples(blocks, whole)
        s = _summary(blocks)
        assert (s.count, s.names, s.features, s.issues) == \
            (len(whole), whole.names, whole.features, whole.issues)
    # the chunks overlap in log time: one block even at 1 byte a block
    from mcap.reader import make_reader
    with open(next(bag.glob('*.mcap')), 'rb') as f:
        assert len(make_reader(f).get_summary().chunk_indexes) >= 2
    assert len(list(bagio.iter_joint_states(bag, block_bytes=1))) == 1
    fallback = list(bagio.iter_joint_states(bag, direct=False, block_bytes=50_000))
    assert len(fallback) > 3
    _same_samples(fallback, whole)
    assert _summary(fallback).issues == whole.issues


def test_a_broken_message_is_named_by_its_index_in_the_bag(tmp_path):
    bag = tmp_path / 'bag'
    good = bagio.encode_joint_state('lobe_1', 5, 0.0, 0.0)
    with bagio.BagWriter(bag) as w:
        for k in range(20_000):
            w.write(JS, 10 + k, good if k != 15_000 else b'\x00\x07' + good[2:])
    with pytest.raises(InputError, match=r'joint_states\[15000\]'):
        bagio.read_joint_states(bag)
    with pytest.raises(InputError, match=r'joint_states\[15000\]'):
        list(bagio.iter_joint_states(bag, block_bytes=1))
    with pytest.raises(InputError, match='block_bytes'):
        list(bagio.iter_joint_states(bag, block_bytes=0))


def _max_rel_diff(a, b) -> float:
    """Largest relative difference of the numbers of two JSON values (inf if they
    differ in anything else)."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return math.inf
        return max((_max_rel_diff(a[k], b[k]) for k in a), default=0.0)
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return math.inf
        return max((_max_rel_diff(x, y) for x, y in zip(a, b)), default=0.0)
    if isinstance(a, float) and isinstance(b, float):
        return 0.0 if a == b else abs(a - b) / max(abs(a), abs(b))
    return 0.0 if a == b else math.inf


@pytest.fixture(scope='module')
def rounds_bag(tmp_path_factory):
    """The default scene measured 3 times in a row, 1 um noise (27 000 samples)."""
    bag = tmp_path_factory.mktemp('stream') / 'rounds'
    write_sim_bag(bag, load_scene(default_scene_path()),
                  SimParams(samples_per_rev=1800, probe_noise=1e-6, seed=3), rounds=3)
    return bag


def test_streamed_report_equals_whole_bag_report(rounds_bag):
    reports = []
    for block in (1 << 40, 1, 300_000):   # one block = the whole-bag read; then chunks
        res = run_offline(rounds_bag, [MetrologyCore()], block_bytes=block)
        assert res.samples == 27_000 and res.joint_issues == ()
        reports.append(res.report())
    for other in reports[1:]:
        assert _max_rel_diff(reports[0], other) <= 1e-12
    feats = reports[0]['features']
    assert set(feats) == {'lobe_1', 'lobe_2', 'lobe_3', 'lobe_4', 'dowel_pin'}
    assert all(f['status'] == 'ok' and f['samples_received'] == 1800 for f in feats.values())


def test_only_the_last_table_of_a_feature_measured_again_is_kept(rounds_bag):
    every = run_offline(rounds_bag, [MetrologyCore()])
    last = run_offline(rounds_bag, [MetrologyCore()], superseded_tables=False)
    tables = [o.output for o in every.outputs if o.output.topic == '/metrology/lift']
    kept = [o.output for o in last.outputs if o.output.topic == '/metrology/lift']
    assert len(tables) == 15 and len(kept) == 5
    for table in kept:   # the last measurement of each feature
        want = [t for t in tables if t.label == table.label][-1]
        np.testing.assert_allclose(table.data, want.data, rtol=1e-15, atol=0)
    assert _max_rel_diff(every.report(), last.report()) == 0.0
    others = [o for o in every.outputs if o.output.topic != '/metrology/lift']
    assert [o.output.topic for o in others] == \
        [o.output.topic for o in last.outputs if o.output.topic != '/metrology/lift']


_CHILD = '''
import json, sys
from cam_metrology import bagio
from cam_metrology.metrology.core import MetrologyCore
from cam_metrology.offline.replay import run_offline
def status_mb(key):
    with open('/proc/self/status') as f:
        return next(int(l.split()[1]) for l in f if l.startswith(key + ':')) / 1024
run_offline(sys.argv[3], [MetrologyCore()])   # warm-up: every lazy import done
base = status_mb('VmRSS')
if sys.argv[2] == 'whole':
    n = len(bagio.read_joint_states(sys.argv[1]))
else:
    n = run_offline(sys.argv[1], [MetrologyCore()], superseded_tables=False).samples
# VmHWM, not ru_maxrss: Linux keeps the parent's high-water mark in ru_maxrss across
# fork and exec (a big pytest worker would be counted)
peak = status_mb('VmHWM')
print(json.dumps({'samples': n, 'growth_mb': peak - base}))
'''


def _child_growth(bag: Path, mode: str) -> dict:
    """Peak RSS growth [MB] over the RSS after the imports, in a fresh interpreter."""
    small = REPO / 'bags' / 'default_clean'
    done = subprocess.run([sys.executable, '-c', _CHILD, str(bag), mode, str(small)],
                          check=True, capture_output=True, text=True, timeout=600)
    return json.loads(done.stdout)


def test_memory_of_a_long_bag_stays_bounded(tmp_path):
    """360 000 samples of repeated measurements (features of 36 000 samples): the
    streamed analysis grows by less than ``bound`` over a warmed-up interpreter, while
    the whole-bag reader alone (what the analysis did before streaming) grows by more
    (about 500 B a sample)."""
    bag = tmp_path / 'long'
    write_sim_bag(bag, load_scene(default_scene_path()),
                  SimParams(samples_per_rev=36_000, probe_noise=1e-6), rounds=2)
    streamed = _child_growth(bag, 'streamed')
    whole = _child_growth(bag, 'whole')
    assert streamed['samples'] == whole['samples'] == 360_000
    bound = 70.0   # MB: blocks of 4 MB, one feature of 36 000 samples and its analysis
    assert streamed['growth_mb'] < bound
    assert whole['growth_mb'] > bound

"""cam_metrology.wire.loss: lost-sample accounting from sequence numbers (no rclpy).

Truth is constructed: a writer numbers 1..N, a known set is removed (the holes a
keep-last history makes), and the counts must equal the removed set exactly.
"""
from __future__ import annotations

import numpy as np
import pytest

from cam_metrology.wire.loss import ERROR, OK, WARN, FeatureLoss, SequenceLoss, loss_status


def test_no_loss_in_batches_is_ok() -> None:
    acc = SequenceLoss('/t')
    for batch in np.array_split(np.arange(1, 10_001), 7):
        assert acc.add(batch) == []
    assert (acc.received, acc.lost, acc.missed_at_start, acc.level) == (10_000, 0, 0, OK)
    assert acc.summary() == 'no loss on /t (10000 received)'


@pytest.mark.parametrize('batch', [1, 13, 5000])
def test_withheld_samples_are_counted_exactly(batch: int) -> None:
    rng = np.random.default_rng(4)
    seqs = np.arange(1, 20_001)
    withheld = np.sort(rng.choice(np.arange(2, 20_001), size=777, replace=False))
    got = np.setdiff1d(seqs, withheld)
    acc = SequenceLoss('/bench/joint_states')
    holes = []
    for k in range(0, got.size, batch):
        holes += [(k + i, n) for i, n in acc.add(got[k:k + batch])]
    assert acc.lost == 777 and acc.received == 20_000 - 777 and acc.expected == 20_000
    assert acc.level == ERROR
    assert 'lost 777 samples on /bench/joint_states' in acc.summary()
    # each hole sits just before the first sample after a withheld run
    assert sum(n for _, n in holes) == 777
    for i, n in holes:
        assert got[i] - got[i - 1] - 1 == n


def test_keep_last_overflow_at_start_is_missed_not_lost() -> None:
    acc = SequenceLoss('/t')
    holes = acc.add(np.arange(15_001, 20_001))   # depth 5000 kept the last 5000
    assert holes == [(0, 15_000)]
    assert (acc.missed_at_start, acc.lost, acc.level) == (15_000, 0, WARN)
    assert 'missed 15000 samples on /t published before the first one received' \
        in acc.summary()


def test_two_interleaved_publishers_without_loss_count_nothing() -> None:
    rng = np.random.default_rng(9)
    a, b = list(range(1, 3001)), list(range(1, 2001))
    order = []
    while a or b:   # a random interleaving, each publisher in its own order
        src = a if (a and (not b or rng.random() < 0.6)) else b
        order.append(src.pop(0))
    acc = SequenceLoss('/t')
    acc.add(order[:1000])
    acc.add(order[1000:])
    assert (acc.received, acc.lost, acc.missed_at_start) == (5000, 0, 0)
    assert sorted(acc.streams) == [2000, 3000]


def test_two_publishers_with_loss_in_one_of_them() -> None:
    acc = SequenceLoss('/t')
    # publisher A 1..100 then 111..200 (10 lost); publisher B 1..50, in A's gap region
    seq = list(range(1, 101)) + list(range(1, 51)) + list(range(111, 201))
    acc.add(seq)
    assert (acc.lost, acc.received) == (10, 240)


def test_restarted_publisher_is_a_new_stream() -> None:
    acc = SequenceLoss('/t')
    acc.add(range(1, 501))
    acc.add(range(1, 301))   # the simulator run again
    assert (acc.lost, acc.missed_at_start, acc.received) == (0, 0, 800)


def test_feature_attribution_and_status_message() -> None:
    acc, feats = SequenceLoss('/bench/joint_states'), FeatureLoss()
    ids = ['lobe_1'] * 100 + ['lobe_2'] * 100
    seqs = np.arange(1, 201)
    keep = np.ones(200, bool)
    keep[[10, 11, 12]] = False      # inside lobe_1
    keep[[100, 101]] = False        # the first two of lobe_2: between the features
    got_ids = [f for f, k in zip(ids, keep) if k]
    charged = feats.add(got_ids, acc.add(seqs[keep]))
    assert charged == {'lobe_1', 'lobe_2'}
    assert feats.of('lobe_1') == 3 + 2 and feats.of('lobe_2') == 2 and feats.of('pin') == 0
    # a hole at the start of the next batch is charged against the last feature too
    feats.add(['lobe_3'], acc.add([205]))
    assert feats.of('lobe_2') == 2 + 4 and feats.of('lobe_3') == 4
    level, msg = loss_status([acc, SequenceLoss('/bench/feature_done')])
    assert level == ERROR and msg.startswith('lost 9 samples on /bench/joint_states')
    assert loss_status([SequenceLoss('/x')]) == (OK, 'no loss (0 messages received)')


def test_split_feature_and_marking() -> None:
    import json

    from cam_metrology.wire.loss import mark_partial
    from cam_metrology.cores.outputs import Status, StatusOutput, TextOutput

    acc, feats = SequenceLoss('/bench/joint_states'), FeatureLoss()
    feats.add(['lobe_1'] * 50, acc.add(range(1, 51)))
    feats.result_published('lobe_1')          # an idle timeout ended it early
    feats.add(['lobe_1'] * 30 + ['lobe_2'] * 5, acc.add(range(51, 86)))
    feats.result_published('lobe_1')
    assert feats.parts == {'lobe_1': 2} and acc.lost == 0
    outs = mark_partial([
        StatusOutput('/metrology/result', (Status('lobe_1', OK, 'measured'),
                                           Status('lobe_2', OK, 'measured'),
                                           Status('skipped/x', OK, 'n/a'))),
        TextOutput('/metrology/report', json.dumps(
            {'features': {'lobe_1': {'status': 'ok'}, 'lobe_2': {'status': 'ok'}}}))],
        feats, [acc])
    one, two, other = outs[0].statuses
    assert one.level == WARN and one.message.startswith('partial data: received in 2 parts')
    assert (one.values['parts'], one.values['partial'], one.values['samples_lost']) == \
        ('2', 'True', '0')
    assert two.level == OK and two.values == {'samples_lost': '0', 'partial': 'False'}
    assert other == Status('skipped/x', OK, 'n/a')
    doc = json.loads(outs[1].text)
    assert doc['features']['lobe_1']['partial'] and not doc['features']['lobe_2']['partial']
    assert doc['input'] == {'samples_lost': 0, 'missed_at_start': 0, 'topics': {
        '/bench/joint_states': {'received': 85, 'lost': 0, 'missed_at_start': 0}}}

"""Samples in the wrong units, as a foreign bench might record them: a probe in mm or
um, an encoder in degrees. The feature fails with a message naming the unit the values
look like (never a traceback, never a number computed from them)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cam_metrology.cli import main
from cam_metrology.metrology.features import (FeatureSamples, encoder_units_hint,
                                              probe_units_problem)


def _fs(theta: np.ndarray, s: np.ndarray) -> FeatureSamples:
    return FeatureSamples('lobe_1', theta, s, np.arange(theta.size, dtype=np.int64),
                          theta.size, 0, 0, 1.0)


@pytest.mark.parametrize('scale, unit', [(1e3, 'millimetres'), (1e6, 'micrometres')])
def test_probe_span_names_the_unit(scale: float, unit: str) -> None:
    th = np.linspace(0, 2 * np.pi, 3600, endpoint=False)
    s = 8e-3 * np.clip(np.cos(th), 0, None)
    assert probe_units_problem(_fs(th, s)) is None
    msg = probe_units_problem(_fs(th, s * scale))
    assert msg is not None and unit in msg and '8 mm' in msg


def test_encoder_hint_only_for_whole_turns_of_360() -> None:
    th = np.linspace(0, 2 * np.pi, 3600, endpoint=False)
    assert encoder_units_hint(_fs(th, 0 * th)) == ''
    assert encoder_units_hint(_fs(th * 40, 0 * th)) == ''     # 40 revolutions in rad
    hint = encoder_units_hint(_fs(np.degrees(th), 0 * th))
    assert 'degrees' in hint and '1 x 360' in hint
    assert '3 x 360' in encoder_units_hint(_fs(np.degrees(3 * th), 0 * th))


def _rescaled(src: Path, dst: Path, joint: str, scale: float) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    with AnyReader([src], default_typestore=ts) as r, Writer(dst, version=9) as w:
        conns = {c.id: w.add_connection(c.topic, c.msgtype, typestore=ts)
                 for c in r.connections}
        for c, t, raw in r.messages():
            if c.topic == '/bench/joint_states':
                m = r.deserialize(raw, c.msgtype)
                pos = m.position.copy()
                pos[list(m.name).index(joint)] *= scale
                m.position = pos
                raw = ts.serialize_cdr(m, c.msgtype)
            w.write(conns[c.id], t, raw)


@pytest.mark.parametrize('joint, scale, words', [
    ('probe', 1e3, 'look like millimetres'),
    ('camshaft', 180.0 / math.pi, 'look like degrees'),
])
def test_analyze_names_wrong_units(tmp_path: Path, capsys, joint: str, scale: float,
                                   words: str) -> None:
    sim = tmp_path / 'sim'
    assert main(['simulate', str(sim), '--quiet', '--samples-per-rev', '720']) == 0
    bag = tmp_path / 'foreign'
    _rescaled(sim, bag, joint, scale)
    out = tmp_path / 'report.json'
    code = main(['analyze', str(bag), '--json', str(out), '--only-metrology'])
    assert code != 0
    report = json.loads(out.read_text(encoding='utf-8'))
    failed = {k: v for k, v in report['features'].items() if v.get('status') == 'failed'}
    assert set(failed) == set(report['features'])
    for feature in failed.values():
        assert words in feature['reason'], feature

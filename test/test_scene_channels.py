"""The bench's channel names from the scene (``channels:``): parsed with one-line errors,
used by the metrology core live (per message) and offline (``analyze`` of a bag whose
samples carry the bench's own joint names in another order), and overridden by the
node's parameters when they name other joints. Truth: the simulated lobe's nose angle."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from cam_design.errors import InputError
from cam_metrology.scene.parse import parse_scene

NAMES = ['lvdt_1', 'spindle', 'cam_encoder']   # the bench's own, in its own order


def _scene_text(config_dir: Path, channels: object = None) -> str:
    doc = yaml.safe_load((config_dir / 'default_scene.yaml').read_text(encoding='utf-8'))
    doc['lobes'] = doc['lobes'][:1]
    doc.pop('dowel_pin', None)
    if channels is not None:
        doc['channels'] = channels
    return yaml.safe_dump(doc, sort_keys=False)


def test_channels_are_parsed_and_bad_names_named_in_one_line(config_dir: Path) -> None:
    scene = parse_scene(_scene_text(config_dir, {'angle_joint': 'cam_encoder',
                                                 'lift_joint': 'lvdt_1'}))
    assert scene.channels.joints == ('cam_encoder', 'lvdt_1')
    assert parse_scene(_scene_text(config_dir)).channels is None
    half = parse_scene(_scene_text(config_dir, {'lift_joint': 'lvdt_1'}))
    assert half.channels.joints == ('camshaft', 'lvdt_1')
    for channels, key in (({'angle_joint': ''}, 'channels.angle_joint'),
                          ({'lift_joint': 3}, 'channels.lift_joint'),
                          ({'angle_joint': 'a', 'lift_joint': 'a'}, 'channels.lift_joint'),
                          (['cam_encoder'], 'channels')):
        with pytest.raises(InputError) as err:
            parse_scene(_scene_text(config_dir, channels))
        assert err.value.key == key and '\n' not in str(err.value)
    warned = parse_scene(_scene_text(config_dir, {'angle_joint': 'e', 'lift': 'x'}))
    assert any(w.startswith('channels.lift: unknown key') for w in warned.warnings)


def _lobe(config_dir: Path):
    from cam_metrology.simulation.bench import SimParams, simulate

    text = _scene_text(config_dir, {'angle_joint': 'cam_encoder', 'lift_joint': 'lvdt_1'})
    run = simulate(parse_scene(text), SimParams(probe_noise=5e-7, seed=3,
                                                samples_per_rev=1800))
    lobe = run.features[0]
    assert lobe.id == 'lobe_1'
    return text, lobe, run.truth['features']['lobe_1']['angle_deg']


def _angle_error(got: float, truth: float) -> float:
    return (got - truth + 180.0) % 360.0 - 180.0


def _message(frame: str, stamp: int, names: list[str], values: list[float]) -> object:
    header = SimpleNamespace(frame_id=frame, stamp=SimpleNamespace(
        sec=stamp // 1_000_000_000, nanosec=stamp % 1_000_000_000))
    return SimpleNamespace(header=header, name=names, position=values)


@pytest.mark.parametrize('params, found', [({}, True),
                                           ({'angle_joint': 'enc_2'}, False)])
def test_the_core_takes_the_scene_names_unless_its_parameters_name_others(
        config_dir: Path, params: dict, found: bool) -> None:
    """Per message (the live path): the scene's names connect the bench; a parameter
    naming another joint wins (its samples lack that joint: NaN, dropped, the feature
    fails naming it)."""
    from cam_metrology.metrology.core import MetrologyCore
    from cam_metrology.wire.topics import FEATURE_DONE, JOINT_STATES

    text, lobe, truth = _lobe(config_dir)
    core = MetrologyCore(params)
    core.set_scene(parse_scene(text))
    assert core.joints == (('cam_encoder', 'lvdt_1') if found else ('enc_2', 'probe'))
    for stamp, theta, s in zip(lobe.stamp_ns.tolist(), lobe.theta.tolist(), lobe.s.tolist()):
        core.handle(JOINT_STATES, _message('lobe_1', stamp, NAMES, [s, 0.0, theta]), stamp)
    core.handle(FEATURE_DONE, SimpleNamespace(data='lobe_1'), 0)
    res = core.results['lobe_1']
    if not found:
        assert res.failed is not None and res.values['samples_nan_dropped'] == lobe.theta.size
        return
    assert res.failed is None, res.failed
    assert abs(_angle_error(res.values['angle_deg'], truth)) < \
        5 * res.values['angle_std_deg'] + 1e-4


def test_analyze_reads_a_bag_by_the_names_of_its_scene(config_dir: Path,
                                                       tmp_path: Path) -> None:
    """A bag whose JointStates carry the bench's names (in another order) and whose
    scene names them: ``analyze`` with no parameter file measures the lobe."""
    from cam_metrology.bagio import BagWriter
    from cam_metrology.offline.analyze import analyze_bag
    from cam_metrology.wire.cdr import encode_named_values, encode_string
    from cam_metrology.wire.topics import FEATURE_DONE, JOINT_STATES, SCENE, TOPIC_TYPES

    text, lobe, truth = _lobe(config_dir)
    rows = np.column_stack((lobe.s, np.zeros(lobe.theta.size), lobe.theta))
    bag = tmp_path / 'bag'
    with BagWriter(bag) as writer:
        for topic in (SCENE, JOINT_STATES, FEATURE_DONE):
            writer.add_topic(topic, TOPIC_TYPES[topic])
        first = int(lobe.stamp_ns[0])
        writer.write(SCENE, first - 1000, encode_string(text))
        for stamp, cdr in zip(lobe.stamp_ns.tolist(),
                              encode_named_values('lobe_1', lobe.stamp_ns, NAMES, rows)):
            writer.write(JOINT_STATES, stamp, cdr)
        writer.write(FEATURE_DONE, int(lobe.stamp_ns[-1]) + 1000, encode_string('lobe_1'))
    feature = analyze_bag(str(bag), only_metrology=True).report['features']['lobe_1']
    assert feature['status'] == 'ok', feature.get('reason')
    assert feature['samples_received'] == lobe.theta.size
    assert abs(_angle_error(feature['angle_deg'], truth)) < \
        5 * feature['angle_std_deg'] + 1e-4

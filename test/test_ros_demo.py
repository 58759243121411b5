"""`cam-bench demo` end to end on a short scene at a high rate (subprocess), two at once.

The demo claims its own domain (flock) and runs every node as a subprocess; the bag
it leaves must open with rosbags and with mcap (no part of this package) and hold
/bench/scene, /bench/joint_states (every sample) and the output topics of every core
that exists and their plot views, each topic with the wire table's QoS; the printed
report scores each feature against /bench/truth.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from test_ros_sim_record import short_scene

pytestmark = pytest.mark.ros

CLI = 'import sys; from cam_metrology.cli import main; sys.exit(main(sys.argv[1:]))'


def test_demo_end_to_end(ros_domain: int, tmp_path: Path, config_dir: Path) -> None:
    from rosbags.highlevel import AnyReader

    from cam_metrology.offline.registry import available_cores

    scene = short_scene(config_dir, tmp_path / 'scene.yaml')
    bag, other = tmp_path / 'demo_bag', tmp_path / 'other_bag'
    env = dict(os.environ)
    env.pop('ROS_DOMAIN_ID', None)   # the demo claims a domain of its own
    # two demos at once: each claims its own domain, neither disturbs the other (a demo
    # fails when its metrology node or recorder lost a sample)
    procs = [subprocess.Popen([sys.executable, '-c', CLI, 'demo', '--scene', str(scene),
                               '--out', str(b), '--rate', '6000', '--timeout', '120'],
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for b in (bag, other)]
    outs = [subprocess.CompletedProcess(p.args, 0, *p.communicate(timeout=240))
            for p in procs]
    for p, o in zip(procs, outs):
        assert p.returncode == 0, o.stdout + o.stderr
    out = outs[0]
    domains = {ln.split('ROS domain ')[1].split()[0] for o in outs
               for ln in o.stdout.splitlines() if 'ROS domain ' in ln}
    assert len(domains) == 2, domains
    with AnyReader([other]) as reader:
        assert sum(c.msgcount for c in reader.connections
                   if c.topic == '/bench/joint_states') == 2 * 3600
    assert f'bag: {bag}' in out.stdout
    assert 'demo took' in out.stdout
    cores = available_cores()
    with AnyReader([bag]) as reader:
        counts: dict[str, int] = {}
        for conn in reader.connections:
            counts[conn.topic] = counts.get(conn.topic, 0) + conn.msgcount
        scene_msgs = [reader.deserialize(raw, c.msgtype).data for c, _, raw in
                      reader.messages([c for c in reader.connections
                                       if c.topic == '/bench/scene'])]
    assert scene_msgs == [scene.read_text(encoding='utf-8')]
    assert counts['/bench/joint_states'] == 2 * 3600
    assert counts['/bench/feature_done'] == 2 and counts['/bench/truth'] == 1
    for name, cls in cores.items():
        for topic in cls.publications:
            assert topic in counts, f'{name}: {topic} not in the bag'
        result = f'/{name}/result'
        if result in cls.publications:
            assert counts[result] >= 1, f'{name} published no result:\n{out.stdout}'
    if 'metrology' in cores:
        assert counts['/metrology/report'] >= 1
        for fid in ('lobe_1', 'dowel_pin'):
            line = next(ln for ln in out.stdout.splitlines() if ln.startswith(fid))
            assert 'FAILED' not in line, line
    # the plot views of every output are published live and recorded, and every topic
    # of the wire table is stored with the table's QoS (as simulate and analyze store it)
    from cam_metrology import bagio
    from cam_metrology.wire.topics import PLOT_TOPICS, TOPICS, qos_of
    assert set(PLOT_TOPICS) <= set(counts), sorted(counts)
    for topic in PLOT_TOPICS:
        assert counts[topic] >= 1, topic
    # one values message per feature and one for the part at each final report
    import json
    finals = sum(json.loads(m.msg.data).get('final') is True
                 for m in bagio.iter_messages(bag, ['/metrology/report']))
    assert finals >= 1
    assert counts['/metrology/values'] == 3 * finals
    qos = bagio.topic_qos_yaml(bag)
    for topic in TOPICS:
        if topic in qos:
            assert qos[topic] == qos_of(topic).bag_yaml(), topic
    # the mcap library reads the same bag with no part of this package
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    with open(next(bag.glob('*.mcap')), 'rb') as f:
        topics = [c.topic for _, c, _, _ in make_reader(
            f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()]
    assert topics.count('/bench/joint_states') == 2 * 3600
    assert '/bench/scene' in topics

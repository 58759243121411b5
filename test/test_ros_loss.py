"""Loss is never silent, live over rclpy (one process, this session's isolated domain).

A metrology-like node (fake bulk core through ``CoreNode``, threaded worker) and the
recorder both subscribe to /bench/joint_states with a shallow keep-last reader (depth
500). The test's publisher (keep last 10 000) sends 100 samples, lets both take them,
then sends 3000 more while neither node is spun (a node fed faster than it processes):
each reader keeps only the last 500, so exactly 2500 are lost mid-stream. Truth is the
construction; checked: each node's /diagnostics says 'lost 2500 samples on
/bench/joint_states' at ERROR, the feature's status is marked partial with the number,
the report carries it, and the recorder's bag holds its loss record.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cam_metrology.cores.outputs import OK, Status, StatusOutput, TextOutput

pytestmark = pytest.mark.ros

N1, N2, DEPTH = 100, 3000, 500


class BulkCore:
    """Counts samples per feature; a status per feature on feature_done; a report."""

    name = 'fake_metrology'
    subscriptions = {'/bench/joint_states': 'sensor_msgs/msg/JointState',
                     '/bench/feature_done': 'std_msgs/msg/String'}
    publications = {'/metrology/result': 'diagnostic_msgs/msg/DiagnosticArray',
                    '/metrology/report': 'std_msgs/msg/String'}

    def __init__(self, params: dict[str, Any] | None = None) -> None:
        self.counts: dict[str, int] = {}

    def handle_samples(self, frame_ids: Any, stamp_ns: Any, theta: Any, s: Any,
                       rx_ns: int | None = None) -> list[Any]:
        for fid in np.asarray(frame_ids).tolist():
            self.counts[fid] = self.counts.get(fid, 0) + 1
        return []

    def handle(self, topic: str, msg: Any, stamp_ns: int) -> list[Any]:
        fid = str(msg.data)
        return [StatusOutput('/metrology/result', (
            Status(fid, OK, 'measured', {'samples_received': str(self.counts.get(fid, 0))},
                   'lobe'),)),
                TextOutput('/metrology/report', '{"features": {"%s": {"status": "ok"}}}' % fid)]

    def tick(self, now_ns: int) -> list[Any]:
        return []

    def finish(self) -> list[Any]:
        return []


def test_overrun_node_and_recorder_report_the_exact_loss(ros_domain: int,
                                                         tmp_path: Path) -> None:
    import json

    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.duration import Duration
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from cam_metrology import bagio
    from cam_metrology.nodes.adapter import CoreNode
    from cam_metrology.nodes.recorder import RecorderNode
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.wire.topics import QosSpec, qos_of

    shallow = QosSpec(reliable=True, depth=DEPTH)
    proc = RosProcess(handle_signals=False)
    bag = tmp_path / 'bag'
    try:
        node = proc.add(CoreNode(BulkCore, context=proc.context, samples_qos=shallow))
        rec = proc.add(RecorderNode(context=proc.context, output=bag,
                                    reader_qos={'/bench/joint_states': shallow}))
        test = proc.add(Node('loss_test', context=proc.context))
        pub = test.create_publisher(JointState, '/bench/joint_states',
                                    profile(QosSpec(reliable=True, depth=10_000)))
        done = test.create_publisher(String, '/bench/feature_done',
                                     profile(qos_of('/bench/feature_done')))
        got: dict[str, list[Any]] = {'diag': [], 'result': [], 'report': []}
        test.create_subscription(DiagnosticArray, '/diagnostics',
                                 lambda m: got['diag'].extend(m.status),
                                 profile(qos_of('/diagnostics')))
        test.create_subscription(DiagnosticArray, '/metrology/result',
                                 lambda m: got['result'].extend(m.status),
                                 profile(qos_of('/metrology/result')))
        test.create_subscription(String, '/metrology/report',
                                 lambda m: got['report'].append(json.loads(m.data)),
                                 profile(qos_of('/metrology/report')))
        assert proc.spin_until(lambda: pub.get_subscription_count() == 2
                               and done.get_subscription_count() == 2, 30.0)
        frames = bagio.encode_joint_states('lobe_1', np.arange(N1 + N2, dtype=np.int64),
                                           np.linspace(0, 1, N1 + N2), np.zeros(N1 + N2))
        for f in frames[:N1]:
            pub.publish(f)
        assert proc.spin_until(lambda: node.core.counts.get('lobe_1') == N1
                               and rec.counts['/bench/joint_states'] == N1, 30.0)
        for f in frames[N1:]:          # neither node is spun meanwhile
            pub.publish(f)
        # both readers hold the last DEPTH of them once everything is acknowledged
        assert pub.wait_for_all_acked(Duration(seconds=30))
        done.publish(String(data='lobe_1'))
        assert proc.spin_until(lambda: node.core.counts.get('lobe_1') == N1 + DEPTH
                               and any(st.name == 'lobe_1' for st in got['result'])
                               and got['report'], 30.0)
        node.publish_diagnostics(force=True)
        rec.publish_diagnostics(force=True)
        assert proc.spin_until(lambda: {'fake_metrology: input', 'recorder: input'}
                               <= {st.name for st in got['diag'] if st.level != b'\x00'},
                               30.0)
        node.stop_worker()
    finally:
        if 'rec' in locals():
            rec.close()
        proc.close()
    lost = N2 - DEPTH
    want = f'lost {lost} samples on /bench/joint_states ({N1 + DEPTH} of {N1 + N2} received)'
    for name in ('fake_metrology: input', 'recorder: input'):
        st = [s for s in got['diag'] if s.name == name][-1]
        assert st.level == b'\x02' and st.message == want, (name, st.message)
        values = {kv.key: kv.value for kv in st.values}
        assert values['lost/bench/joint_states'] == str(lost)
    feature = [s for s in got['result'] if s.name == 'lobe_1'][-1]
    values = {kv.key: kv.value for kv in feature.values}
    assert feature.level == b'\x01' and feature.message.startswith(
        f'partial data: lost {lost} samples on /bench/joint_states')
    assert values['samples_lost'] == str(lost) and values['partial'] == 'True'
    assert values['samples_received'] == str(N1 + DEPTH)
    report = got['report'][-1]
    assert report['features']['lobe_1']['samples_lost'] == lost
    assert report['input']['samples_lost'] == lost
    # the recorder's bag: every sample it got, and its loss record
    assert bagio.bag_topics(bag)['/bench/joint_states'][1] == N1 + DEPTH
    records = [st for m in bagio.iter_messages(bag, ['/diagnostics'])
               for st in bagio.statuses_from_msg(m.msg)]
    assert records[-1]['message'] == want
    assert records[-1]['values']['lost/bench/joint_states'] == str(lost)

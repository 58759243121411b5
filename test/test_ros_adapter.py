"""The generic CoreNode adapter over a fake core, live over rclpy (one process).

Checks: parameters declared with descriptors and passed to the core; the scene and
samples reach ``handle`` with the right types; TableOutput / StatusOutput /
TextOutput come out as Float64MultiArray / DiagnosticArray / String with the layout
of architecture.md; ``finish`` publishes a transient-local report that a late
subscriber still receives.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from cam_metrology.cores.outputs import ERROR, OK, Status, StatusOutput, TableOutput, TextOutput

pytestmark = pytest.mark.ros


class FakeCore:
    """Publishes a table and a status per 3 samples, a report on finish."""

    name = 'fake_metrology'
    PARAMETERS = {'gain': (2.0, 'multiplies s'), 'label': ('lobe', 'table label'),
                  'speeds': ((1500.0, 3000.0), 'a float array')}
    subscriptions = {'/bench/joint_states': 'sensor_msgs/msg/JointState',
                     '/bench/scene': 'std_msgs/msg/String'}
    publications = {'/metrology/lift': 'std_msgs/msg/Float64MultiArray',
                    '/metrology/result': 'diagnostic_msgs/msg/DiagnosticArray',
                    '/metrology/report': 'std_msgs/msg/String'}

    def __init__(self, params: dict[str, Any] | None = None) -> None:
        self.params = dict(params or {})
        self.scene: str | None = None
        self.rows: list[tuple[float, float]] = []
        self.order: list[str] = []

    def handle(self, topic: str, msg: Any, stamp_ns: int) -> list[Any]:
        self.order.append(topic)
        if topic == '/bench/scene':
            self.scene = msg.data
            return []
        theta = msg.position[list(msg.name).index('camshaft')]
        s = msg.position[list(msg.name).index('probe')]
        self.rows.append((theta, s * self.params['gain']))
        if len(self.rows) % 3:
            return []
        data = np.array(self.rows[-3:])
        return [TableOutput('/metrology/lift', f'{self.params["label"]}_{len(self.rows)}',
                            ('alpha_rad', 'lift_m'), data),
                StatusOutput('/metrology/result', (
                    Status('lobe_1', OK, 'ok', {'angle_deg': '12.5'}),
                    Status('skipped/pin', ERROR, 'no pin')), stamp_ns=123_000_000_456)]

    def tick(self, now_ns: int) -> list[Any]:
        return []

    def finish(self) -> list[Any]:
        return [TextOutput('/metrology/report', f'{{"n": {len(self.rows)}}}')]


def test_adapter_publishes_core_outputs(ros_domain: int) -> None:
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, String

    from cam_metrology.nodes.adapter import CoreNode
    from cam_metrology.nodes.runtime import RosProcess
    from cam_metrology.nodes.topics import profile
    from cam_metrology.wire.topics import TOPICS

    proc = RosProcess(['x', '--ros-args', '-p', 'fake_metrology:gain:=10.0'],
                      handle_signals=False)
    try:
        node = proc.add(CoreNode(FakeCore, context=proc.context))
        assert node.core.params == {'gain': 10.0, 'label': 'lobe', 'speeds': [1500.0, 3000.0]}
        desc = node.describe_parameter('gain')
        assert desc.description == 'multiplies s'
        assert node.get_parameter('speeds').type_ == Parameter.Type.DOUBLE_ARRAY
        probe = proc.add(proc_node(proc, 'probe'))
        got: dict[str, list[Any]] = {'/metrology/lift': [], '/metrology/result': []}
        for topic, cls in (('/metrology/lift', Float64MultiArray),
                           ('/metrology/result', DiagnosticArray)):
            probe.create_subscription(cls, topic, got[topic].append, profile(TOPICS[topic][1]))
        scene_pub = probe.create_publisher(String, '/bench/scene',
                                           profile(TOPICS['/bench/scene'][1]))
        js_pub = probe.create_publisher(JointState, '/bench/joint_states',
                                        profile(TOPICS['/bench/joint_states'][1]))
        scene_pub.publish(String(data='camshaft_id: fake'))
        assert proc.spin_until(lambda: js_pub.get_subscription_count() >= 1
                               and node.core.scene is not None
                               and all(node.subscription_count(t) >= 1 for t in got), 10.0)
        for k in range(6):
            js_pub.publish(JointState(name=['probe', 'camshaft'],
                                      position=[0.001 * k, 0.1 * k]))
        assert proc.spin_until(lambda: len(got['/metrology/result']) == 2, 10.0)
        assert proc.spin_until(lambda: len(got['/metrology/lift']) == 2, 10.0)
        assert node.core.order[0] == '/bench/scene'
        table = got['/metrology/lift'][1]
        assert [d.label for d in table.layout.dim] == ['lobe_6', 'alpha_rad,lift_m']
        assert [d.size for d in table.layout.dim] == [3, 2]
        assert [d.stride for d in table.layout.dim] == [6, 2]
        expect = np.array([[0.1 * k, 0.01 * k] for k in (3, 4, 5)])
        assert np.allclose(np.frombuffer(table.data).reshape(3, 2), expect, rtol=0, atol=1e-15)
        diag = got['/metrology/result'][0]
        assert (diag.header.stamp.sec, diag.header.stamp.nanosec) == (123, 456)
        assert [s.name for s in diag.status] == ['lobe_1', 'skipped/pin']
        assert [s.level for s in diag.status] == [b'\x00', b'\x02']
        assert [(kv.key, kv.value) for kv in diag.status[0].values] == [('angle_deg', '12.5')]
        assert node.finish(5.0)
        # a subscriber created after the report still gets it (transient local)
        reports: list[Any] = []
        probe.create_subscription(String, '/metrology/report', reports.append,
                                  profile(TOPICS['/metrology/report'][1]))
        assert proc.spin_until(lambda: bool(reports), 10.0)
        assert reports[0].data == '{"n": 6}'
        assert node.errors == 0
    finally:
        proc.close()


def proc_node(proc: Any, name: str) -> Any:
    """A plain node in the process' context."""
    from rclpy.node import Node
    return Node(name, context=proc.context)


@pytest.mark.parametrize('override, message', [
    # rclpy's InvalidParameterTypeException (string parameter, integer given) -> InputError
    ('label:=5', "fake_metrology.label: got 5; expected a string"),
    # float parameters are dynamically typed: checked after declaring
    ('gain:=abc', "fake_metrology.gain: got 'abc'; expected a number (integer or float)"),
])
def test_adapter_wrong_typed_parameter(ros_domain: int, override: str, message: str) -> None:
    from cam_design.errors import InputError
    from cam_metrology.nodes.adapter import CoreNode
    from cam_metrology.nodes.runtime import RosProcess

    proc = RosProcess(['x', '--ros-args', '-p', f'fake_metrology:{override}'],
                      handle_signals=False)
    try:
        with pytest.raises(InputError) as exc:
            CoreNode(FakeCore, context=proc.context)
        assert str(exc.value) == message
    finally:
        proc.close()

"""Pure helpers of the ROS layer (no graph, no domain): argument and topic parsing,
the demo's truth scoring and readiness counts, QoS conversion."""
from __future__ import annotations


import pytest

from cam_design.errors import InputError

pytestmark = pytest.mark.ros


def test_topic_specs_and_graph_counts() -> None:
    from cam_metrology.nodes.bench_sim import parse_graph_counts
    from cam_metrology.nodes.recorder import parse_topic_specs

    assert parse_topic_specs('/a, /b:std_msgs/msg/String') == {
        '/a': None, '/b': 'std_msgs/msg/String'}
    with pytest.raises(InputError, match="topics: got 'b:std_msgs/msg/String'"):
        parse_topic_specs('/a, b:std_msgs/msg/String')     # relative names are rejected
    assert parse_topic_specs(['/x:sensor_msgs/msg/JointState']) == {
        '/x': 'sensor_msgs/msg/JointState'}
    assert parse_graph_counts(' /m/lift=2,/m/result=3 ,') == {'/m/lift': 2, '/m/result': 3}
    assert parse_graph_counts('') == {}
    for bad in ('/a', 'a=2', '/a=x', '/a=-1'):
        with pytest.raises(InputError, match='wait_graph'):
            parse_graph_counts(bad)


def test_ros_arguments() -> None:
    from cam_metrology.nodes import ros_arguments

    assert ros_arguments(None) == ['cam-bench']
    assert ros_arguments('p.yaml', ['--ros-args', '-p', 'a:=1']) == [
        'cam-bench', '--ros-args', '--params-file', 'p.yaml', '-p', 'a:=1']
    assert ros_arguments(None, ['-p', 'a:=1']) == ['cam-bench', '--ros-args', '-p', 'a:=1']


def test_truth_scoring_and_report_table() -> None:
    from cam_metrology.nodes.demo import report_lines, truth_angle_deg, wrap180

    truth = {'features': {'lobe_1': {'angle_deg': 359.99, 'phase_error_deg': 0.45},
                          'lobe_2': {'angle_deg': -90.0}, 'dowel_pin': {'angle_rad': 1.0}}}
    assert truth_angle_deg(truth, 'lobe_1') == pytest.approx(359.99)
    assert truth_angle_deg(truth, 'lobe_2') == pytest.approx(270.0)
    # one spelling, the one simulate writes (features.<id>.angle_deg)
    assert truth_angle_deg(truth, 'dowel_pin') is None
    assert truth_angle_deg(truth, 'lobe_9') is None
    assert wrap180(0.02 - 359.99) == pytest.approx(0.03)
    assert wrap180(-180.0) == 180.0
    report = {'camshaft_id': 'X', 'features': {
        'lobe_1': {'angle_deg': 0.02, 'angle_std_deg': 0.001, 'phase_error_deg': 0.5},
        'lobe_2': {'angle_deg': None, 'status': 'failed', 'reason': 'too few samples'}},
        'skipped': [{'what': 'pin', 'why': 'no pin'}]}
    lines = report_lines(report, truth)
    row1 = next(ln for ln in lines if ln.startswith('lobe_1')).split()
    assert row1[1:] == ['0.0200', '3.60', '0.5000', '359.9900', '108.00', '180.00']   # arcsec
    assert 'FAILED: too few samples' in next(ln for ln in lines if ln.startswith('lobe_2'))
    assert lines[-1] == 'skipped: pin (no pin)'
    assert report_lines(None, truth) == ['no metrology report']


def test_downstream_subscriptions() -> None:
    from cam_metrology.nodes.demo import downstream_subscriptions

    class Metrology:
        subscriptions = {'/bench/joint_states': 'sensor_msgs/msg/JointState'}
        publications = {'/metrology/lift': 'std_msgs/msg/Float64MultiArray',
                        '/metrology/result': 'diagnostic_msgs/msg/DiagnosticArray',
                        '/metrology/report': 'std_msgs/msg/String'}

    class Recon:
        subscriptions = {'/bench/scene': 'std_msgs/msg/String',
                         '/metrology/lift': 'std_msgs/msg/Float64MultiArray'}
        publications = {'/reconstruction/profile': 'std_msgs/msg/Float64MultiArray'}

    need = downstream_subscriptions([Metrology, Recon])
    assert need == {'/metrology/lift': 2,            # recorder + reconstruction
                    '/metrology/result': 2,          # recorder + the demo's monitor
                    '/metrology/report': 2,
                    '/reconstruction/profile': 1}    # recorder only; no dynamics topics


def test_qos_and_message_classes() -> None:
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

    from cam_metrology.nodes.topics import message_class, profile, type_name_of
    from cam_metrology.wire.topics import TOPICS, qos_of

    scene = profile(qos_of('/bench/scene'))
    assert (scene.durability, scene.depth) == (DurabilityPolicy.TRANSIENT_LOCAL, 1)
    samples = profile(qos_of('/bench/joint_states'))
    # keep-all (back-pressure, nothing overwritten) or keep-last deep enough
    assert samples.history == HistoryPolicy.KEEP_ALL or (
        samples.history == HistoryPolicy.KEEP_LAST and samples.depth >= 1000)
    assert samples.reliability == ReliabilityPolicy.RELIABLE
    assert qos_of('/unknown').depth == 100
    for type_name, _ in TOPICS.values():
        assert type_name_of(message_class(type_name)) == type_name
    assert message_class('std_msgs/String').__name__ == 'String'
    with pytest.raises(ValueError):
        message_class('String')

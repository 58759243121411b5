"""Topics, message types and QoS of cam-bench as plain data (no rclpy).

The one table of the graph: the bench inputs, every node output, the plot topics and
``/diagnostics``. Every user reads it from here: the live nodes and the recorder
(``nodes/qos.py`` turns a ``QosSpec`` into an rclpy ``QoSProfile``), ``simulate``, the
offline replay and the bag writer (``QosSpec.bag_yaml``: the rosbag2
``offered_qos_profiles`` text stored per topic). So a topic has the same type and QoS
whoever publishes or records it (test/test_wire.py).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    'QosSpec', 'LATCHED', 'SAMPLES', 'EVENTS', 'RESULTS', 'PLOT_POINTS', 'STATUS_QOS',
    'STRING', 'TABLE', 'STATUS', 'JOINT_STATE',
    'SCENE', 'JOINT_STATES', 'FEATURE_DONE', 'TRUTH', 'METROLOGY_RESULT', 'METROLOGY_LIFT',
    'METROLOGY_REPORT', 'RECONSTRUCTION_PROFILE', 'RECONSTRUCTION_RESULT',
    'DYNAMICS_MOTION', 'DYNAMICS_RESULT', 'DIAGNOSTICS', 'METROLOGY_VALUES',
    'PLOT_LIFT', 'PLOT_PROFILE', 'PLOT_MOTION',
    'TOPICS', 'BENCH_TOPICS', 'OUTPUT_TOPICS', 'PLOT_TOPICS', 'TOPIC_TYPES',
    'LATCHED_TOPICS', 'qos_of', 'type_of', 'qos_yaml', 'default_qos_yaml',
    'CAMSHAFT_JOINT', 'PROBE_JOINT', 'JOINT_TRAJECTORY', 'JOINT_TRAJECTORY_TYPE', 'BLOCKS',
    'SAMPLE_TOPICS',
    'CAMSHAFT_JOINT', 'PROBE_JOINT', 'RIG_JOINT_STATES', 'RIG_TOPICS', 'VALVE_JOINT',
    'RIG_RESULT', 'RIG_MOTION', 'PLOT_RIG', 'RIG_GRAPH', 'RIG_JOINT_TRAJECTORY',
    'BLOCK_TOPICS',
]

#: joints of a bench sample (``/bench/joint_states``), looked up by name
CAMSHAFT_JOINT = 'camshaft'
PROBE_JOINT = 'probe'
#: joint of a rig sample (``/rig/joint_states``): the valve lift [m] (velocity [m/s])
VALVE_JOINT = 'valve'


@dataclass(frozen=True)
class QosSpec:
    """Reliability, durability and history of a topic.

    ``depth`` is the keep-last depth a publisher offers and a bag stores;
    ``keep_all`` makes the live publishers and subscriptions KEEP_ALL (the bag still
    says keep last ``depth``: what a replaying ``ros2 bag play`` offers).
    """

    reliable: bool = True
    transient_local: bool = False
    depth: int = 10
    keep_all: bool = False

    def bag_yaml(self) -> str:
        """rosbag2 ``offered_qos_profiles`` YAML of this QoS (what a bag stores)."""
        return qos_yaml(transient_local=self.transient_local, depth=self.depth,
                        reliable=self.reliable)


#: scene, truth, report: the last message is what matters; late joiners get it
LATCHED = QosSpec(reliable=True, transient_local=True, depth=1)
#: /bench/joint_states. Live: reliable KEEP_ALL on both sides of cam-bench's own graph
#: (back-pressure instead of loss, docs/ros.md). Bags store keep last 1000: the depth
#: the contract asks of a bench publisher and the depth of every committed fixture
#: bag, so a replayed bag offers what a real bench offers.
SAMPLES = QosSpec(reliable=True, transient_local=False, depth=1000, keep_all=True)
#: /bench/joint_trajectory (blocks of samples): as SAMPLES; a bag stores keep last 100
#: blocks (100 000 samples at 1000 samples per block)
BLOCKS = QosSpec(reliable=True, transient_local=False, depth=100, keep_all=True)
EVENTS = QosSpec(reliable=True, transient_local=False, depth=10)
#: node outputs: reliable, offered transient local (a late subscriber, e.g. the
#: recorder on a loaded machine, still gets the last 100 messages)
RESULTS = QosSpec(reliable=True, transient_local=True, depth=100)
#: plot topics: one message per curve point, so a burst of a feature's curve (at
#: most ``plots.MAX_POINTS`` points per curve, a few curves per feature) must fit
PLOT_POINTS = QosSpec(reliable=True, transient_local=True, depth=10000)
#: /diagnostics: node health and every per-feature status
STATUS_QOS = QosSpec(reliable=True, transient_local=True, depth=100)

STRING = 'std_msgs/msg/String'
TABLE = 'std_msgs/msg/Float64MultiArray'
STATUS = 'diagnostic_msgs/msg/DiagnosticArray'
JOINT_STATE = 'sensor_msgs/msg/JointState'
JOINT_TRAJECTORY_TYPE = 'trajectory_msgs/msg/JointTrajectory'

SCENE = '/bench/scene'
JOINT_STATES = '/bench/joint_states'
#: blocks of samples: one JointTrajectory point per sample (docs/contract.md §2)
JOINT_TRAJECTORY = '/bench/joint_trajectory'
FEATURE_DONE = '/bench/feature_done'
#: valve-train rig input: joints 'camshaft' [rad] and 'valve' [m], frame_id = run
RIG_JOINT_STATES = '/rig/joint_states'
#: the rig's samples in blocks: JointTrajectory as /bench/joint_trajectory, joints
#: 'camshaft' [rad] and 'valve' [m], frame_id = run
RIG_JOINT_TRAJECTORY = '/rig/joint_trajectory'
TRUTH = '/bench/truth'
METROLOGY_RESULT = '/metrology/result'
METROLOGY_LIFT = '/metrology/lift'
METROLOGY_REPORT = '/metrology/report'
RECONSTRUCTION_PROFILE = '/reconstruction/profile'
RECONSTRUCTION_RESULT = '/reconstruction/result'
DYNAMICS_MOTION = '/dynamics/valve_motion'
DYNAMICS_RESULT = '/dynamics/result'
DIAGNOSTICS = '/diagnostics'
#: per-part numbers (angles, uncertainties, phases, verdicts) as named entries
METROLOGY_VALUES = '/metrology/values'
#: curves, one message per point (plots.py): y against angle with no array arithmetic
PLOT_LIFT = '/plot/lift'
PLOT_PROFILE = '/plot/profile'
PLOT_MOTION = '/plot/valve_motion'
#: rig node: per run a status (speed, separation, residual) and the averaged lift table
RIG_RESULT = '/rig/result'
RIG_MOTION = '/rig/valve_motion'
PLOT_RIG = '/plot/rig_motion'

#: topic -> (ROS type name, QoS): the bench inputs first, then every output.
TOPICS: dict[str, tuple[str, QosSpec]] = {
    SCENE: (STRING, LATCHED),
    JOINT_STATES: (JOINT_STATE, SAMPLES),
    JOINT_TRAJECTORY: (JOINT_TRAJECTORY_TYPE, BLOCKS),
    FEATURE_DONE: (STRING, EVENTS),
    RIG_JOINT_STATES: (JOINT_STATE, SAMPLES),
    RIG_JOINT_TRAJECTORY: (JOINT_TRAJECTORY_TYPE, BLOCKS),
    TRUTH: (STRING, LATCHED),
    METROLOGY_RESULT: (STATUS, RESULTS),
    METROLOGY_LIFT: (TABLE, RESULTS),
    METROLOGY_REPORT: (STRING, LATCHED),
    RECONSTRUCTION_PROFILE: (TABLE, RESULTS),
    RECONSTRUCTION_RESULT: (STATUS, RESULTS),
    DYNAMICS_MOTION: (TABLE, RESULTS),
    DYNAMICS_RESULT: (STATUS, RESULTS),
    DIAGNOSTICS: (STATUS, STATUS_QOS),
    METROLOGY_VALUES: (JOINT_STATE, RESULTS),
    PLOT_LIFT: (JOINT_STATE, PLOT_POINTS),
    PLOT_PROFILE: (JOINT_STATE, PLOT_POINTS),
    PLOT_MOTION: (JOINT_STATE, PLOT_POINTS),
    RIG_RESULT: (STATUS, RESULTS),
    RIG_MOTION: (TABLE, RESULTS),
    PLOT_RIG: (JOINT_STATE, PLOT_POINTS),
}

BENCH_TOPICS = (SCENE, TRUTH, JOINT_STATES, JOINT_TRAJECTORY, FEATURE_DONE)
#: the two forms of the sample stream: one sample per message, and blocks
SAMPLE_TOPICS = (JOINT_STATES, JOINT_TRAJECTORY)
PLOT_TOPICS = (METROLOGY_VALUES, PLOT_LIFT, PLOT_PROFILE, PLOT_MOTION)
#: the valve-train rig's inputs (docs/contract.md "Valve-train rig")
RIG_TOPICS = (RIG_JOINT_STATES, RIG_JOINT_TRAJECTORY)
#: the topics that carry samples in blocks (JointTrajectory, ``bagio.decode_joint_blocks``)
BLOCK_TOPICS = (JOINT_TRAJECTORY, RIG_JOINT_TRAJECTORY)
#: every topic of the rig's own graph (its input, the rig node's outputs and plot view):
#: not part of a bench bag, nor of what ``analyze`` and the bench ``demo`` produce
RIG_GRAPH = (RIG_JOINT_STATES, RIG_JOINT_TRAJECTORY, RIG_RESULT, RIG_MOTION, PLOT_RIG)
#: what the node cores publish (the plot views and /diagnostics are derived from it)
OUTPUT_TOPICS = tuple(t for t in TOPICS
                      if t not in BENCH_TOPICS and t not in PLOT_TOPICS and t != DIAGNOSTICS
                      and t not in RIG_TOPICS and t != PLOT_RIG)
#: topic -> ROS type name
TOPIC_TYPES: dict[str, str] = {t: ty for t, (ty, _) in TOPICS.items()}
LATCHED_TOPICS = frozenset(t for t, (_, q) in TOPICS.items() if q == LATCHED)


def qos_of(topic: str, default: QosSpec = RESULTS) -> QosSpec:
    """QoS of a known topic (as published and stored in bags), ``default`` for others."""
    return TOPICS[topic][1] if topic in TOPICS else default


def type_of(topic: str) -> str | None:
    """ROS type name of a known topic, None for others."""
    return TOPIC_TYPES.get(topic)


def qos_yaml(*, transient_local: bool = False, depth: int = 10,
             reliable: bool = True) -> str:
    """rosbag2 v9 ``offered_qos_profiles`` YAML for one publisher with this QoS.

    The text ``ros2 bag record`` stores per topic; ``ros2 bag play`` reads it to offer
    the same durability (transient local topics are latched on replay).
    """
    from io import StringIO

    from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness,
                                    QosReliability, QosTime)
    from rosbags.rosbag2.metadata import dump_qos_v9
    from ruamel.yaml import YAML

    profile = Qos(
        history=QosHistory.KEEP_LAST, depth=int(depth),
        reliability=QosReliability.RELIABLE if reliable else QosReliability.BEST_EFFORT,
        durability=(QosDurability.TRANSIENT_LOCAL if transient_local
                    else QosDurability.VOLATILE),
        deadline=QosTime(0, 0), lifespan=QosTime(0, 0),
        liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=QosTime(0, 0),
        avoid_ros_namespace_conventions=False)
    stream = StringIO()
    yaml = YAML(typ='safe')
    yaml.default_flow_style = False
    yaml.dump(dump_qos_v9([profile]), stream)
    return stream.getvalue().strip()


def default_qos_yaml(topic: str) -> str:
    """The QoS YAML a bag stores for ``topic`` (``qos_of(topic).bag_yaml()``)."""
    return qos_of(topic).bag_yaml()

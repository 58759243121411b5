"""rosbag2 (MCAP) bags: the face of the package (one import for the rest of cam-bench).

No rclpy here (architecture.md): messages are encoded with the rosbags ROS2_JAZZY
typestore (or, for ``sensor_msgs/JointState``, with an equivalent ``struct`` encoder
checked byte for byte against it in the tests), and bags are written with
``rosbags.rosbag2.Writer(version=9, storage_plugin=MCAP)`` so that they open with
rosbags, with ``mcap`` + ``mcap_ros2`` and with ``ros2 bag`` (docs/ros.md).

Writing: ``BagWriter`` takes CDR bytes as received (the recorder path: nothing is
re-encoded) and writes the rosbag2 QoS metadata of each topic (``/bench/scene``,
``/bench/truth`` and ``/metrology/report`` as transient local, depth 1, so that a
replay latches them). Reading: ``iter_messages`` decodes every message with
rosbags' ``AnyReader`` in log-time order; ``read_joint_states`` is the fast path
for ``/bench/joint_states``: it decodes the JointState CDR of the whole topic with
numpy (no per-message objects), looking the joints up by name.

Units: stamps in ns (int), angles rad, lifts m.
"""

from __future__ import annotations

# one module per concern: writer (BagWriter), opening (a bag opened for reading),
# joints (the JointState fast path), stream (blocks of chunks), reader (messages,
# topics, scenes), copying (copy and recover); the wire contract is in wire/
from cam_metrology.bagio.copying import (  # noqa: F401
    BagTopic,
    Recovered,
    add_topics_like,
    bag_connections,
    copy_bag,
    recover_bag,
    topic_definitions,
    topic_qos_yaml)
from cam_metrology.bagio.joints import (  # noqa: F401
    JointIssue,
    JointSamples,
    LightJointState,
    MAX_NAME_BYTES,
    decode_joint_states,
    light_joint_states,
    read_joint_states)
from cam_metrology.bagio.opening import (  # noqa: F401
    BagMessage,
    looks_like_bag,
    open_reader)
from cam_metrology.bagio.reader import (  # noqa: F401
    bag_topics,
    iter_messages)
from cam_metrology.bagio.stream import (  # noqa: F401
    JointSummary,
    STREAM_BLOCK_BYTES,
    iter_joint_states)
from cam_metrology.bagio.writer import (  # noqa: F401
    BagWriter,
    MCAP_MAGIC)
from cam_metrology.wire.cdr import (  # noqa: F401
    decode,
    encode_joint_state,
    encode_joint_state_positions,
    encode_joint_states,
    encode_string,
    typestore)
from cam_metrology.wire.layouts import (  # noqa: F401
    encode_output,
    encode_statuses,
    encode_table,
    statuses_from_msg,
    table_from_msg)
from cam_metrology.wire.topics import (  # noqa: F401
    CAMSHAFT_JOINT,
    JOINT_STATES,
    PROBE_JOINT,
    TOPIC_TYPES,
    default_qos_yaml,
    qos_yaml)

__all__ = [
    'JOINT_STATES', 'CAMSHAFT_JOINT', 'PROBE_JOINT', 'TOPIC_TYPES', 'BagWriter',
    'BagMessage', 'JointSamples', 'LightJointState', 'typestore', 'qos_yaml',
    'default_qos_yaml', 'encode_joint_state', 'encode_joint_states',
    'encode_joint_state_positions', 'encode_string', 'encode_output', 'encode_table',
    'encode_statuses', 'decode', 'table_from_msg', 'statuses_from_msg', 'iter_messages',
    'read_joint_states', 'decode_joint_states', 'light_joint_states', 'bag_topics',
    'BagTopic', 'bag_connections', 'JointIssue', 'MAX_NAME_BYTES',
    'topic_qos_yaml', 'copy_bag', 'recover_bag', 'Recovered', 'add_topics_like',
    'topic_definitions', 'iter_joint_states', 'JointSummary', 'STREAM_BLOCK_BYTES',
]

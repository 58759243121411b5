"""CDR (little endian, ROS 2 Jazzy) of the messages cam-bench writes, without rclpy.

The fast path: ``std_msgs/String``, ``sensor_msgs/JointState`` and
``std_msgs/Float64MultiArray`` are packed with ``struct``/numpy (byte-identical to
the rosbags typestore's ``serialize_cdr``, test/test_wire.py); other types go through
the rosbags ROS2_JAZZY typestore (``typestore()``), which also decodes everything
(``decode``). The live nodes publish these bytes as they are (a serialized
message), the bag writer stores them, the offline replay decodes them: one encoder
per layout.
"""
from __future__ import annotations

import struct
from typing import Any, Sequence

import numpy as np

from cam_design.errors import InputError
from cam_metrology.wire.topics import CAMSHAFT_JOINT, PROBE_JOINT

__all__ = ['typestore', 'decode', 'encode_string', 'encode_joint_state',
           'encode_joint_states', 'encode_joint_state_positions', 'encode_float64_array',
           'encode_named_values']

_TYPESTORE: Any = None
_U32 = struct.Struct('<I')
_HEAD = b'\x00\x01\x00\x00'   # CDR little endian encapsulation


def typestore() -> Any:
    """The rosbags ROS2_JAZZY typestore (created once)."""
    global _TYPESTORE
    if _TYPESTORE is None:
        from rosbags.typesys import Stores, get_typestore

        _TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
    return _TYPESTORE


def decode(cdr: bytes | memoryview, msgtype: str) -> Any:
    """Decode CDR bytes of ROS type ``msgtype`` into a rosbags message object."""
    return typestore().deserialize_cdr(cdr, msgtype)


def _align(out: bytearray, n: int) -> None:
    """Pad ``out`` so that the next field starts at a multiple of ``n`` (after the
    4-byte encapsulation header)."""
    pad = (-(len(out) - 4)) % n
    if pad:
        out += b'\0' * pad


def _string(out: bytearray, text: str) -> None:
    """Append a CDR string (4-aligned length incl. NUL, bytes, NUL)."""
    _align(out, 4)
    raw = text.encode('utf-8')
    out += _U32.pack(len(raw) + 1)
    out += raw
    out += b'\0'


def _header(out: bytearray, stamp_ns: int, frame_id: str) -> None:
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    out += struct.pack('<iI', sec, nanosec)
    _string(out, frame_id)


def _float64s(out: bytearray, values: Any) -> None:
    arr = np.ascontiguousarray(values, dtype='<f8').reshape(-1)
    _align(out, 4)
    out += _U32.pack(arr.size)
    if arr.size:
        _align(out, 8)
        out += arr.tobytes()


def encode_string(text: str) -> bytes:
    """CDR of a ``std_msgs/String``."""
    out = bytearray(_HEAD)
    _string(out, text)
    return bytes(out)


def encode_joint_state_positions(frame_id: str, stamp_ns: int, names: Sequence[str],
                                 positions: Sequence[float],
                                 velocities: Sequence[float] = ()) -> bytes:
    """CDR of a ``sensor_msgs/JointState`` with ``names``, ``positions`` (any lengths:
    also used to build irregular test bags), optional ``velocities``, no effort."""
    out = bytearray(_HEAD)
    _header(out, stamp_ns, frame_id)
    _align(out, 4)
    out += _U32.pack(len(names))
    for name in names:
        _string(out, name)
    _float64s(out, positions)
    _float64s(out, velocities)
    _float64s(out, ())
    return bytes(out)


def encode_joint_state(frame_id: str, stamp_ns: int, theta: float, s: float,
                       names: Sequence[str] = (CAMSHAFT_JOINT, PROBE_JOINT)) -> bytes:
    """CDR of a bench sample: ``position`` = (theta [rad], s [m]) of joints ``names``."""
    return encode_joint_state_positions(frame_id, stamp_ns, names, (theta, s))


def encode_joint_states(frame_id: str, stamp_ns: Any, theta: Any, s: Any) -> list[bytes]:
    """CDR of many bench samples of one feature at once (vectorised).

    Same bytes as ``encode_joint_state(frame_id, stamp_ns[k], theta[k], s[k])`` for
    every k; stamps [ns] as int64, theta [rad], s [m] as float64 arrays of one length.
    """
    st = np.asarray(stamp_ns, dtype=np.int64).reshape(-1)
    th = np.asarray(theta, dtype='<f8').reshape(-1)
    sv = np.asarray(s, dtype='<f8').reshape(-1)
    if not st.size == th.size == sv.size:
        raise InputError('encode_joint_states', (st.size, th.size, sv.size),
                         'stamps, theta and s of the same length')
    template = np.frombuffer(encode_joint_state(frame_id, 0, 0.0, 0.0), dtype=np.uint8)
    size = template.size
    mat = np.empty((st.size, size), dtype=np.uint8)
    mat[:] = template
    sec, nsec = np.divmod(st, 1_000_000_000)
    mat[:, 4:8] = sec.astype('<i4').view(np.uint8).reshape(-1, 4)
    mat[:, 8:12] = nsec.astype('<u4').view(np.uint8).reshape(-1, 4)
    mat[:, size - 24:size - 16] = th.view(np.uint8).reshape(-1, 8)
    mat[:, size - 16:size - 8] = sv.view(np.uint8).reshape(-1, 8)
    return [row.tobytes() for row in mat]


def encode_named_values(frame_id: str, stamp_ns: int, names: Sequence[str],
                        rows: Any) -> list[bytes]:
    """CDR of one JointState per row of ``rows`` (n x len(names)), all with the same
    ``names`` and ``frame_id``, stamped ``stamp_ns`` (an int or one per row)."""
    data = np.ascontiguousarray(rows, dtype='<f8')
    if data.ndim != 2 or data.shape[1] != len(names):
        raise InputError(f'{frame_id} values', data.shape, f'(rows, {len(names)})')
    stamps = np.broadcast_to(np.asarray(stamp_ns, dtype=np.int64), (data.shape[0],))
    if not data.shape[0]:
        return []
    template = np.frombuffer(encode_joint_state_positions(
        frame_id, 0, names, np.zeros(len(names))), dtype=np.uint8)
    size = template.size
    mat = np.empty((data.shape[0], size), dtype=np.uint8)
    mat[:] = template
    sec, nsec = np.divmod(stamps, 1_000_000_000)
    mat[:, 4:8] = sec.astype('<i4').view(np.uint8).reshape(-1, 4)
    mat[:, 8:12] = nsec.astype('<u4').view(np.uint8).reshape(-1, 4)
    start = size - 8 - 8 * len(names)   # positions end where velocity, effort (empty) begin
    mat[:, start:size - 8] = data.view(np.uint8).reshape(data.shape[0], -1)
    return [row.tobytes() for row in mat]


def encode_float64_array(dims: Sequence[tuple[str, int, int]], data: Any,
                         data_offset: int = 0) -> bytes:
    """CDR of a ``std_msgs/Float64MultiArray``: ``dims`` = (label, size, stride) each."""
    out = bytearray(_HEAD)
    out += _U32.pack(len(dims))
    for label, size, stride in dims:
        _string(out, label)
        _align(out, 4)
        out += struct.pack('<II', int(size), int(stride))
    _align(out, 4)
    out += _U32.pack(int(data_offset))
    _float64s(out, data)
    return bytes(out)

"""CDR (little endian, ROS 2 Jazzy) of the messages cam-bench writes, without rclpy.

The fast path: ``std_msgs/String``, ``sensor_msgs/JointState``,
``trajectory_msgs/JointTrajectory`` (blocks of samples) and
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
           'encode_named_values', 'encode_joint_trajectory', 'encode_sample_blocks']

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


def _header_and_names(stamp_ns: int, frame_id: str, names: Sequence[str]) -> bytearray:
    """The CDR start shared by JointState and JointTrajectory: encapsulation, header
    (stamp [ns], frame id), then the string sequence ``names``."""
    out = bytearray(_HEAD)
    _header(out, stamp_ns, frame_id)
    _align(out, 4)
    out += _U32.pack(len(names))
    for name in names:
        _string(out, name)
    return out


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
                                 positions: Sequence[float] | np.ndarray,
                                 velocities: Sequence[float] = ()) -> bytes:
    """CDR of a ``sensor_msgs/JointState`` with ``names``, ``positions`` (any lengths:
    also used to build irregular test bags), optional ``velocities``, no effort."""
    out = _header_and_names(stamp_ns, frame_id, names)
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


def encode_joint_trajectory(frame_id: str, stamp_ns: int, names: Sequence[str],
                            positions: Any, offsets_ns: Any, velocities: Any = None) -> bytes:
    """CDR of a ``trajectory_msgs/JointTrajectory`` block of samples (vectorised).

    ``positions`` (n x len(names)) in joint order [rad, m], ``offsets_ns`` (n,) each
    point's ``time_from_start`` [ns] (>= 0) from ``stamp_ns`` (``header.stamp``, the
    first sample's time); ``velocities`` (n x len(names)) or None (empty);
    accelerations and effort empty. Byte-identical to the rosbags typestore's
    ``serialize_cdr`` (test/test_blocks.py).
    """
    pos = np.ascontiguousarray(positions, dtype='<f8')
    if pos.ndim == 1 and len(names) == 1:
        pos = pos.reshape(-1, 1)
    off = np.asarray(offsets_ns, dtype=np.int64).reshape(-1)
    if pos.ndim != 2 or pos.shape[1] != len(names) or pos.shape[0] != off.size:
        raise InputError('encode_joint_trajectory', (pos.shape, off.size),
                         f'positions of shape (n, {len(names)}) and n offsets')
    if off.size and int(off.min()) < 0:
        raise InputError('encode_joint_trajectory.time_from_start', int(off.min()),
                         'offsets >= 0 ns')
    vel = None if velocities is None else np.ascontiguousarray(velocities, dtype='<f8')
    if vel is not None and vel.shape != pos.shape:
        raise InputError('encode_joint_trajectory.velocities', vel.shape,
                         f'velocities of shape {pos.shape} (one per position)')
    out = _header_and_names(stamp_ns, frame_id, names)
    _align(out, 4)
    n, k = pos.shape
    out += _U32.pack(n)
    if n == 0:
        return bytes(out)
    sec, nsec = np.divmod(off, 1_000_000_000)
    if vel is not None:
        return _points_with_velocities(out, pos, vel, sec, nsec)
    # the first point alone (its doubles may need a 4-byte pad); from the second on
    # every point starts at 4 mod 8, so the rest is one packed record array
    _float64s(out, pos[0])
    out += b'\0' * 12   # empty velocities, accelerations, effort
    out += struct.pack('<iI', int(sec[0]), int(nsec[0]))
    if n > 1:
        rec = np.zeros(n - 1, dtype=[('count', '<u4'), ('pos', '<f8', (k,)),
                                     ('empty', '<u4', (3,)), ('sec', '<i4'), ('nsec', '<u4')])
        rec['count'] = k
        rec['pos'] = pos[1:]
        rec['sec'] = sec[1:]
        rec['nsec'] = nsec[1:]
        out += rec.tobytes()
    return bytes(out)


def _points_with_velocities(out: bytearray, pos: Any, vel: Any, sec: Any, nsec: Any,
                            ) -> bytes:
    """``out`` (up to the points' count) + the points with positions and velocities
    (accelerations and effort empty): the first point alone, the rest one packed
    record array (every point after the first starts 8-aligned)."""
    n, k = pos.shape
    _float64s(out, pos[0])
    _float64s(out, vel[0])
    out += b'\0' * 8   # empty accelerations, effort
    out += struct.pack('<iI', int(sec[0]), int(nsec[0]))
    if n > 1:
        assert (len(out) - 4) % 8 == 0
        rec = np.zeros(n - 1, dtype=[('count', '<u4'), ('pad', '<u4'), ('pos', '<f8', (k,)),
                                     ('vcount', '<u4'), ('vpad', '<u4'), ('vel', '<f8', (k,)),
                                     ('empty', '<u4', (2,)), ('sec', '<i4'), ('nsec', '<u4')])
        rec['count'] = k
        rec['vcount'] = k
        rec['pos'] = pos[1:]
        rec['vel'] = vel[1:]
        rec['sec'] = sec[1:]
        rec['nsec'] = nsec[1:]
        out += rec.tobytes()
    return bytes(out)


def encode_sample_blocks(frame_id: str, stamp_ns: Any, theta: Any, s: Any,
                         per_message: int,
                         names: Sequence[str] = (CAMSHAFT_JOINT, PROBE_JOINT),
                         more: Sequence[Any] = (), velocity: Any = None,
                         ) -> list[tuple[int, bytes]]:
    """One feature's samples as JointTrajectory blocks of at most ``per_message``
    samples: (stamp of the block's last sample [ns], CDR) per block. Stamps [ns] int64
    (non-decreasing), theta [rad], s [m] of one length; joints ``names`` (angle, lift,
    then one name per column of ``more``: further joints' positions); ``velocity``: the
    lift joint's velocity [m/s] or None (the other joints' velocities are then 0)."""
    st = np.asarray(stamp_ns, dtype=np.int64).reshape(-1)
    pos = np.column_stack([np.asarray(theta, dtype='<f8').reshape(-1),
                           np.asarray(s, dtype='<f8').reshape(-1)] +
                          [np.asarray(c, dtype='<f8').reshape(-1) for c in more])
    vel = None
    if velocity is not None:
        vel = np.zeros_like(pos)
        vel[:, 1] = np.asarray(velocity, dtype='<f8').reshape(-1)
    if st.size != pos.shape[0]:
        raise InputError('encode_sample_blocks', (st.size, pos.shape[0]),
                         'stamps, theta and s of the same length')
    if isinstance(per_message, bool) or int(per_message) < 1:
        raise InputError('samples_per_message', per_message, 'an integer >= 1')
    out = []
    for a in range(0, st.size, int(per_message)):
        b = min(st.size, a + int(per_message))
        t0 = int(st[a])
        out.append((int(st[b - 1]), encode_joint_trajectory(
            frame_id, t0, names, pos[a:b], st[a:b] - t0,
            None if vel is None else vel[a:b])))
    return out

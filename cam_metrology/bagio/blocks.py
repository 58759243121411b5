"""Blocks of samples: ``trajectory_msgs/JointTrajectory`` messages decoded into samples.

One public function, ``decode_joint_blocks``: the CDR of many JointTrajectory messages
(as received raw by a live node, or read from a bag) -> one ``JointSamples`` entry per
point. A point is a sample: its positions are looked up by joint name in
``joint_names`` (``joints``: the angle and lift joint names, e.g. the node parameters
``angle_joint`` and ``lift_joint``), its time is ``header.stamp`` +
``time_from_start``, its feature ``header.frame_id``. Any topic carrying this layout
can reuse it (``topic`` names the messages in issues).

A block that cannot give its samples is reported, never silently used: a ``JointIssue``
names the first such block (``topic[i].field``), the value and what would work, and
counts the blocks. Blocks with a missing joint, positions of another length than
``joint_names``, a ``time_from_start`` going backwards or invalid, samples that
overlap the next block in time (a block straddling a feature boundary) or a
``frame_id`` that differs from the blocks on both sides of it (inside one feature's
blocks) give NaN samples (dropped and counted by the feature, the frame id of the
surrounding feature); an empty block, an invalid ``header.stamp`` and an unreadable
or truncated message give none. The rest is decoded as usual. The checks between
neighbouring blocks see the blocks decoded together (a live batch, or a streamed read
of a bag: about 4 MB of chunks at a time).

Speed: a block whose points share one layout (every block cam-bench and a usual
bench write) is read with strided numpy views (no per-point Python); other blocks are
walked point by point. Units: stamps ns, angles rad, lifts m.

With ``extras=True`` a block also gives the lift joint's velocity (its ``velocities``
when a point has one per joint name, as a vibrometer measures it; NaN otherwise) and
the positions of its further joints by name (channels such as a spring force): the
same values a JointState sample gives in ``velocity`` and ``position``.
"""
from __future__ import annotations

import struct
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_metrology.bagio.joints import BLOCK_ISSUES, JointIssue, JointSamples
from cam_metrology.wire.topics import CAMSHAFT_JOINT, JOINT_TRAJECTORY, PROBE_JOINT

__all__ = ['decode_joint_blocks', 'decode_block_buffer', 'block_sample_count']

#: most joint names in one block (a longer list is an unreadable message)
MAX_JOINTS = 4096
_NS = 1_000_000_000

# issue kinds, in the order they are listed (JointIssue.order)
_ENCAPSULATION, _TRUNCATED, _STAMP, _EMPTY, _ANGLE, _LIFT, _LENGTHS, _BACKWARDS, \
    _FRAME, _OVERLAP = range(BLOCK_ISSUES, BLOCK_ISSUES + 10)


class _Bad(Exception):
    """A block that cannot give samples: (kind, field, value, expected, points)."""


def decode_joint_blocks(chunks: Sequence[bytes], log_ns: NDArray[np.int64] | None = None,
                        first: int = 0, *, topic: str = JOINT_TRAJECTORY,
                        joints: tuple[str, str] = (CAMSHAFT_JOINT, PROBE_JOINT),
                        extras: bool = False) -> JointSamples:
    """The samples of JointTrajectory CDR messages ``chunks`` (one per block).

    ``log_ns``: each message's bag log (or receive) time [ns] (zeros if None); every
    sample of a block gets its block's. ``first``: index on the topic of the first
    message (named in issues). ``joints``: (angle joint, lift joint) names.
    ``JointSamples.block_sizes`` gives the samples of each message (0 for a block that
    gave none), in order. ``extras``: also the lift velocity and further joints
    (``JointSamples.lift_velocity``, ``others``).
    """
    n = len(chunks)
    logs = np.zeros(n, dtype=np.int64) if log_ns is None else np.asarray(log_ns, np.int64)
    lengths = np.fromiter((len(c) for c in chunks), dtype=np.int64, count=n)
    starts = np.zeros(n, dtype=np.int64)
    if n:
        np.cumsum(lengths[:-1], out=starts[1:])
    return decode_block_buffer(b''.join(chunks), starts, lengths, logs, first,
                               topic=topic, joints=joints, extras=extras)


def decode_block_buffer(data: bytes | bytearray, starts: NDArray[np.int64],
                        lengths: NDArray[np.int64], log_ns: NDArray[np.int64],
                        first: int = 0, *, topic: str = JOINT_TRAJECTORY,
                        joints: tuple[str, str] = (CAMSHAFT_JOINT, PROBE_JOINT),
                        extras: bool = False) -> JointSamples:
    """``decode_joint_blocks`` of the messages at ``data[starts:starts+lengths]``."""
    view = memoryview(data)
    blocks: list[_Block] = []
    problems: dict[int, list[Any]] = {}
    for k, (a, size) in enumerate(zip(starts.tolist(), lengths.tolist())):
        try:
            blocks.append(_decode_one(data, view, a, size, joints, extras))
        except _Bad as bad:
            kind, fld, value, expected, block = bad.args
            blocks.append(block)
            entry = problems.setdefault(kind, [k, fld, value, expected, 0])
            entry[4] += 1
    _cross_checks(blocks, problems)
    out = _assemble(blocks, np.asarray(log_ns, dtype=np.int64), problems, first, topic)
    if extras:
        out.lift_velocity, out.others = _assemble_extras(blocks)
    return out


class _Block:
    """One decoded message: frame id, header stamp [ns], joint names, per-point
    stamps [ns], theta [rad], s [m] (NaN when the block is unusable); ``more``: with
    extras, the lift velocity (key None) and further joints' positions by name."""

    __slots__ = ('frame', 'stamp', 'names', 'stamps', 'theta', 's', 'usable', 'more')

    def __init__(self, frame: str, stamp: int, names: tuple[str, ...],
                 stamps: NDArray[np.int64], theta: NDArray[np.float64],
                 s: NDArray[np.float64], usable: bool = True) -> None:
        self.frame, self.stamp, self.names = frame, stamp, names
        self.stamps, self.theta, self.s, self.usable = stamps, theta, s, usable
        self.more: dict[str | None, NDArray[np.float64]] = {}

    def spoil(self) -> None:
        """Keep the samples' count and times, drop their values (NaN)."""
        self.theta = np.full(self.theta.size, np.nan)
        self.s = np.full(self.s.size, np.nan)
        self.more = {}
        self.usable = False


_EMPTY_I = np.zeros(0, dtype=np.int64)
_EMPTY_F = np.zeros(0)


def _nothing(frame: str = '', stamp: int = 0, names: tuple[str, ...] = ()) -> _Block:
    return _Block(frame, stamp, names, _EMPTY_I, _EMPTY_F, _EMPTY_F, usable=False)


def _decode_one(data: Any, view: memoryview, a: int, size: int,
                joints: tuple[str, str], extras: bool = False) -> _Block:
    """One JointTrajectory message at ``data[a:a+size]`` (raises _Bad with a block)."""
    end = a + size
    if size < 16 or data[a] != 0 or data[a + 1] > 1:
        raise _Bad(_ENCAPSULATION, '', bytes(view[a:a + 4]).hex(),
                   'plain CDR encapsulation (00 00 or 00 01) as ROS 2 writes it', _nothing())
    e = '<' if data[a + 1] == 1 else '>'
    u32 = struct.Struct(e + 'I').unpack_from
    base = a + 4

    def need(off: int) -> None:
        if off > end:
            raise _Bad(_TRUNCATED, '', f'{size} bytes',
                       'a complete trajectory_msgs/JointTrajectory CDR message', _nothing())

    sec, nsec = struct.unpack_from(e + 'iI', data, base)
    flen = u32(data, base + 8)[0]
    need(base + 12 + flen)
    frame = bytes(view[base + 12:base + 11 + flen]).decode('utf-8', errors='replace') \
        if flen else ''
    stamp = sec * _NS + nsec
    off = _al(base + 12 + flen, base, 4)
    need(off + 4)
    count = u32(data, off)[0]
    off += 4
    if count > MAX_JOINTS:
        raise _Bad(_TRUNCATED, '.joint_names', f'{count} names',
                   f'at most {MAX_JOINTS} joint names', _nothing(frame, stamp))
    names = []
    for _ in range(count):
        off = _al(off, base, 4)
        need(off + 4)
        nlen = u32(data, off)[0]
        need(off + 4 + nlen)
        names.append(bytes(view[off + 4:off + 3 + nlen]).decode('utf-8', errors='replace'))
        off += 4 + nlen
    names_t = tuple(names)
    off = _al(off, base, 4)
    need(off + 4)
    npts = u32(data, off)[0]
    off += 4
    if nsec >= _NS:
        raise _Bad(_STAMP, '.header.stamp', f'nanosec {nsec}',
                   'a valid time (nanosec < 1e9)', _nothing(frame, stamp, names_t))
    if npts == 0:
        raise _Bad(_EMPTY, '.points', '0 points', 'at least one point (sample) per block',
                   _nothing(frame, stamp, names_t))
    if npts * 24 > end - off:
        need(end + 1)
    points = _points_uniform(data, off, end, base, e, npts) or \
        _points_walk(data, off, end, base, e, npts, need)
    dsec, dnsec = points.durations()
    rel = dsec * _NS + dnsec
    stamps = stamp + rel
    nan = np.full(npts, np.nan)
    block = _Block(frame, stamp, names_t, stamps, nan, nan)
    for kind, joint in ((_ANGLE, joints[0]), (_LIFT, joints[1])):
        if joint not in names_t:
            block.usable = False
            raise _Bad(kind, '.joint_names', list(names_t),
                       f'a joint named {joint!r} (joints are looked up by name; the node '
                       'parameters angle_joint and lift_joint name the bench\'s joints)', block)
    bad_len = points.counts != len(names_t)
    if np.any(bad_len):
        j = int(np.argmax(bad_len))
        block.usable = False
        raise _Bad(_LENGTHS, f'.points[{j}].positions',
                   f'{int(np.broadcast_to(points.counts, (npts,))[j])} values for '
                   f'{len(names_t)} joint_names', 'one position per joint name', block)
    if int(dnsec.max()) >= _NS:
        j = int(np.argmax(dnsec >= _NS))
        block.usable = False
        raise _Bad(_STAMP, f'.points[{j}].time_from_start', f'nanosec {int(dnsec[j])}',
                   'a valid duration (nanosec < 1e9)', block)
    if rel[0] < 0 or (npts > 1 and not bool(np.all(rel[1:] >= rel[:-1]))):
        back = np.diff(rel) < 0
        j = int(np.argmax(back)) + 1 if np.any(back) else 0
        block.usable = False
        raise _Bad(_BACKWARDS, f'.points[{j}].time_from_start',
                   f'{int(rel[j])} ns after {int(rel[j - 1]) if j else 0} ns',
                   'offsets >= 0 from header.stamp that never decrease (points in '
                   'acquisition order)', block)
    block.theta = points.f64(names_t.index(joints[0]))
    block.s = points.f64(names_t.index(joints[1]))
    if extras:
        block.more = _extras(points, names_t, joints)
    return block


def _extras(points: Any, names: tuple[str, ...], joints: tuple[str, str],
            ) -> dict[str | None, NDArray[np.float64]]:
    """The lift joint's velocity [m/s] (key None; NaN at points without one velocity
    per joint name) and the further joints' positions by name."""
    more: dict[str | None, NDArray[np.float64]] = {
        name: points.f64(k) for k, name in enumerate(names) if name not in joints}
    more[None] = points.velocity(names.index(joints[1]), len(names))
    return more


def _al(off: int, base: int, k: int) -> int:
    """``off`` aligned to ``k`` bytes relative to the CDR payload start ``base``."""
    return off + (-(off - base)) % k


def _point_layout(data: Any, off: int, base: int, e: str, end: int,
                  ) -> tuple[int, tuple[int, int, int, int], int, int, int] | None:
    """(positions offset, (positions, velocities, accelerations, effort counts),
    duration offset, end, velocities offset) of the point at ``off``; None past
    ``end``."""
    u32 = struct.Struct(e + 'I').unpack_from
    counts = []
    pos = vel = 0
    for k in range(4):
        off = _al(off, base, 4)
        if off + 4 > end:
            return None
        c = u32(data, off)[0]
        off += 4
        if c:
            off = _al(off, base, 8)
        if k == 0:
            pos = off
        elif k == 1:
            vel = off
        off += 8 * c
        counts.append(c)
    off = _al(off, base, 4)
    if off + 8 > end:
        return None
    return pos, (counts[0], counts[1], counts[2], counts[3]), off, off + 8, vel


class _Strided:
    """Points of one layout from the second on: point 0 at its own offsets, points
    1..n-1 every ``stride`` bytes from ``s1`` (positions at ``s1 + pos``, duration at
    ``s1 + dur``); read with strided numpy views (no per-point Python)."""

    def __init__(self, data: Any, e: str, first: tuple[int, int, int], s1: int,
                 rel: tuple[int, int, int], stride: int, n: int, count: int,
                 vel_count: int = 0) -> None:
        self.data, self.e, self.first, self.s1 = data, e, first, s1
        self.rel, self.stride, self.n, self.counts = rel, stride, n, count
        self.vel_count = vel_count

    def _column(self, dtype: str, first_off: int, rel: int) -> NDArray[Any]:
        out = np.empty(self.n, dtype=np.dtype(dtype).newbyteorder('='))
        out[0] = np.frombuffer(self.data, dtype=self.e + dtype, count=1, offset=first_off)[0]
        if self.n > 1:
            out[1:] = np.ndarray((self.n - 1,), dtype=self.e + dtype, buffer=self.data,
                                 offset=self.s1 + rel, strides=(self.stride,))
        return out

    def durations(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """(sec, nanosec) of every point's ``time_from_start``."""
        sec = self._column('i4', self.first[1], self.rel[1]).astype(np.int64)
        nsec = self._column('u4', self.first[1] + 4, self.rel[1] + 4).astype(np.int64)
        return sec, nsec

    def f64(self, k: int) -> NDArray[np.float64]:
        """Position ``k`` of every point."""
        return self._column('f8', self.first[0] + 8 * k, self.rel[0] + 8 * k)

    def velocity(self, k: int, joints: int) -> NDArray[np.float64]:
        """Velocity ``k`` of every point (NaN unless there is one per joint)."""
        if self.vel_count != joints:
            return np.full(self.n, np.nan)
        return self._column('f8', self.first[2] + 8 * k, self.rel[2] + 8 * k)


class _Walked:
    """Points walked one by one: per-point offsets of positions and duration."""

    def __init__(self, data: Any, e: str, pos: NDArray[np.int64], dur: NDArray[np.int64],
                 counts: NDArray[np.int64], vel: NDArray[np.int64] | None = None,
                 vel_counts: NDArray[np.int64] | None = None) -> None:
        self.data, self.e, self.pos, self.dur, self.counts = data, e, pos, dur, counts
        self.vel = np.zeros_like(pos) if vel is None else vel
        self.vel_counts = np.zeros_like(pos) if vel_counts is None else vel_counts

    def _at(self, fmt: str, offsets: NDArray[np.int64]) -> list[Any]:
        unpack = struct.Struct(self.e + fmt).unpack_from
        return [unpack(self.data, o)[0] for o in offsets.tolist()]

    def durations(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """(sec, nanosec) of every point's ``time_from_start``."""
        return (np.array(self._at('i', self.dur), dtype=np.int64),
                np.array(self._at('I', self.dur + 4), dtype=np.int64))

    def f64(self, k: int) -> NDArray[np.float64]:
        """Position ``k`` of every point (NaN where a point has fewer)."""
        ok = self.counts > k
        out = np.full(self.pos.size, np.nan)
        if np.any(ok):
            out[ok] = self._at('d', self.pos[ok] + 8 * k)
        return out

    def velocity(self, k: int, joints: int) -> NDArray[np.float64]:
        """Velocity ``k`` of every point (NaN where a point has not one per joint)."""
        ok = self.vel_counts == joints
        out = np.full(self.pos.size, np.nan)
        if np.any(ok):
            out[ok] = self._at('d', self.vel[ok] + 8 * k)
        return out


def _points_uniform(data: Any, off: int, end: int, base: int, e: str, npts: int,
                    ) -> _Strided | None:
    """The points of a block whose points share one layout (checked for every point,
    vectorised); None for another block."""
    firsts = []
    o = off
    for _ in range(min(npts, 3)):   # the layout is periodic from the 2nd point on
        lay = _point_layout(data, o, base, e, end)
        if lay is None:
            return None
        firsts.append((o, lay))
        o = lay[3]
    counts = firsts[0][1][1]
    if any(lay[1] != counts for _, lay in firsts):
        return None
    first = (firsts[0][1][0], firsts[0][1][2], firsts[0][1][4])
    if npts == 1:
        return _Strided(data, e, first, 0, (0, 0, 0), 1, 1, counts[0], counts[1])
    s1 = firsts[1][0]
    rel = (firsts[1][1][0] - s1, firsts[1][1][2] - s1, firsts[1][1][4] - s1)
    stride = firsts[1][1][3] - s1
    if npts > 2 and firsts[2][1][3] - firsts[2][0] != stride:
        return None   # the layout changes from point to point (alignment): walk it
    m = npts - 1
    if s1 + m * stride > end:
        return None
    for k, c in enumerate(counts):   # every count of every point as the layout says
        at = _count_offset(firsts[1][1], s1, base, k)
        got = np.ndarray((m,), dtype=e + 'u4', buffer=data, offset=at, strides=(stride,))
        if got.min() != c or got.max() != c:
            return None
    return _Strided(data, e, first, s1, rel, stride, npts, counts[0], counts[1])


def _count_offset(lay: Any, start: int, base: int, k: int) -> int:
    """Byte offset of the k-th sequence count of the point at ``start`` with layout
    ``lay`` (positions, velocities, accelerations, effort)."""
    off = start
    for j in range(4):
        off = _al(off, base, 4)
        if j == k:
            return off
        off += 4
        if lay[1][j]:
            off = _al(off, base, 8)
        off += 8 * lay[1][j]
    raise AssertionError(k)


def _points_walk(data: Any, off: int, end: int, base: int, e: str, npts: int,
                 need: Any) -> _Walked:
    """The points of any block, walked one by one (irregular blocks)."""
    pos = np.zeros(npts, dtype=np.int64)
    counts = np.zeros(npts, dtype=np.int64)
    dur = np.zeros(npts, dtype=np.int64)
    vel = np.zeros(npts, dtype=np.int64)
    vel_counts = np.zeros(npts, dtype=np.int64)
    for j in range(npts):
        lay = _point_layout(data, off, base, e, end)
        if lay is None:
            need(end + 1)
            raise AssertionError('unreachable')
        pos[j], counts[j], dur[j], off = lay[0], lay[1][0], lay[2], lay[3]
        vel[j], vel_counts[j] = lay[4], lay[1][1]
    return _Walked(data, e, pos, dur, counts, vel, vel_counts)


def _cross_checks(blocks: list[_Block], problems: dict[int, list[Any]]) -> None:
    """Checks between neighbouring blocks: a frame id differing from the blocks on both
    sides (inside a feature's blocks: relabelled, spoiled) and samples overlapping the
    next block in time (a block straddling a boundary: spoiled)."""
    for k in range(1, len(blocks) - 1):
        prev, cur, nxt = blocks[k - 1], blocks[k], blocks[k + 1]
        if cur.frame != prev.frame and nxt.frame == prev.frame and cur.stamps.size:
            entry = problems.setdefault(_FRAME, [k, '.header.frame_id',
                                                 f'{cur.frame!r} between blocks of '
                                                 f'{prev.frame!r}',
                                                 'one frame_id for all the blocks of a '
                                                 'feature (a new frame_id starts a new '
                                                 'feature)', 0])
            entry[4] += 1
            cur.frame = prev.frame
            cur.spoil()
    for k in range(len(blocks) - 1):
        cur, nxt = blocks[k], blocks[k + 1]
        if cur.stamps.size and nxt.stamps.size and cur.usable and \
                int(cur.stamps[-1]) >= int(nxt.stamps[0]):
            entry = problems.setdefault(_OVERLAP, [k, '.points',
                                                   f'last sample at {int(cur.stamps[-1])} '
                                                   'ns, not before the first of the next '
                                                   f'block ({int(nxt.stamps[0])} ns, '
                                                   f'frame_id {nxt.frame!r})',
                                                   'blocks in time order, each holding '
                                                   'consecutive samples of one feature '
                                                   '(split a block at a feature boundary)',
                                                   0])
            entry[4] += 1
            cur.spoil()


def _assemble(blocks: list[_Block], log_ns: NDArray[np.int64],
              problems: dict[int, list[Any]], first: int, topic: str) -> JointSamples:
    """The blocks' samples as one JointSamples (issues from ``problems``)."""
    sizes = np.fromiter((b.stamps.size for b in blocks), dtype=np.int64, count=len(blocks))
    total = int(sizes.sum())
    frames: dict[str, int] = {}
    codes = np.fromiter((frames.setdefault(b.frame, len(frames)) for b in blocks),
                        dtype=np.int64, count=len(blocks))
    texts = np.array(list(frames) or [''])
    if texts.dtype.itemsize > 4 * 64:
        texts = texts.astype(object)
    with_samples = sizes > 0
    features = tuple(dict.fromkeys(str(texts[c]) for c in codes[with_samples].tolist()))
    names = tuple(dict.fromkeys(b.names for b in blocks if b.stamps.size))
    issues = tuple(JointIssue(f'{topic}[{first + k}]{fld}', value, expected, count,
                              order=kind)
                   for kind, (k, fld, value, expected, count) in sorted(problems.items()))
    if total == 0:
        return JointSamples(np.zeros(0, dtype=texts.dtype), _EMPTY_I.copy(),
                            _EMPTY_I.copy(), _EMPTY_F.copy(), _EMPTY_F.copy(), names,
                            features, issues, block_sizes=sizes)
    used = [b for b in blocks if b.stamps.size]
    return JointSamples(
        frame_id=texts[np.repeat(codes, sizes)],
        stamp_ns=np.concatenate([b.stamps for b in used]).astype(np.int64, copy=False),
        log_ns=np.repeat(np.asarray(log_ns, dtype=np.int64), sizes),
        theta=np.concatenate([b.theta for b in used]),
        s=np.concatenate([b.s for b in used]),
        names=names, features=features, issues=issues, block_sizes=sizes)


def _assemble_extras(blocks: list[_Block],
                     ) -> tuple[NDArray[np.float64] | None, dict[str, NDArray[np.float64]]]:
    """The lift velocity (None when no block carries one) and the further joints'
    positions of the blocks' samples, in ``_assemble``'s order (NaN where a block
    lacks them)."""
    used = [b for b in blocks if b.stamps.size]
    keys = list(dict.fromkeys(k for b in used for k in b.more))

    def column(key: str | None) -> NDArray[np.float64]:
        return np.concatenate([b.more.get(key, np.full(b.stamps.size, np.nan))
                               for b in used]) if used else _EMPTY_F.copy()

    vel = column(None) if None in keys else None
    if vel is not None and not np.any(np.isfinite(vel)):
        vel = None
    return vel, {str(k): column(k) for k in keys if k is not None}


def block_sample_count(cdr: bytes) -> int:
    """Points (samples) of one JointTrajectory CDR message, read from its header
    without decoding the points (0 for a message too short to say)."""
    try:
        if cdr[0] != 0 or cdr[1] > 1:
            return 0
        e = '<' if cdr[1] == 1 else '>'
        u32 = struct.Struct(e + 'I').unpack_from
        base = 4
        off = _al(base + 12 + u32(cdr, base + 8)[0], base, 4)
        count = u32(cdr, off)[0]
        off += 4
        for _ in range(min(count, MAX_JOINTS)):
            off = _al(off, base, 4)
            off += 4 + u32(cdr, off)[0]
        return int(u32(cdr, _al(off, base, 4))[0])
    except (IndexError, struct.error):
        return 0

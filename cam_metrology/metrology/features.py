"""Assembly of features (lobes, dowel pin) from JointState samples (docs/contract.md).

Samples arrive one per message (``handle_joint_state``) or in bulk from the offline
replay (``handle_samples``). Samples of one feature are contiguous: a new
``header.frame_id`` starts a new feature; ``/bench/feature_done`` or an idle timeout
ends one. ``finish_feature`` returns a cleaned ``FeatureSamples``: NaN samples dropped
and counted, exact duplicates dropped and counted, samples sorted by acquisition
stamp. Angles are kept as received (wrapped or unwrapped, either sense); the
estimators work on ``theta mod 2*pi`` so several revolutions simply overlay.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterator, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, unit_slip
from cam_metrology.metrology.spill import SPILL_BYTES, Spool, release, walk

CAMSHAFT, PROBE = 'camshaft', 'probe'


@dataclass(frozen=True)
class FeatureSamples:
    """The cleaned samples of one feature.

    ``theta`` [rad] encoder angles, ``s`` [m] probe readings (arbitrary zero),
    ``stamp_ns`` acquisition stamps, all sorted by stamp; counts of what was received
    and dropped; ``revolutions`` = angular span / 2 pi of the stamp-ordered angles.
    """

    feature_id: str
    theta: NDArray[np.float64]
    s: NDArray[np.float64]
    stamp_ns: NDArray[np.int64]
    received: int
    nan_dropped: int
    duplicates_dropped: int
    revolutions: float


@dataclass
class _OpenFeature:
    """Chunks of one feature still being received: in lists while the feature is
    small, then appended to temporary files (``spill.Spool``) once a column reaches
    ``spill_bytes``, so that a long feature is never held whole in memory."""

    feature_id: str
    spill_bytes: int = SPILL_BYTES
    stamps: list[NDArray[np.int64]] = field(default_factory=list)
    theta: list[NDArray[np.float64]] = field(default_factory=list)
    s: list[NDArray[np.float64]] = field(default_factory=list)
    last_rx_ns: int = 0
    # per-message samples are buffered in lists and turned into arrays in bulk
    pending: list[tuple[int, float, float]] = field(default_factory=list)
    size: int = 0
    spools: tuple[Spool, Spool, Spool] | None = None

    def flush(self) -> None:
        """Move per-message samples into the array chunks."""
        if self.pending:
            arr = np.asarray(self.pending, dtype=float)
            self.pending = []
            self.append(arr[:, 0].astype(np.int64), arr[:, 1], arr[:, 2])

    def append(self, stamps: NDArray[np.int64], theta: NDArray[np.float64],
               s: NDArray[np.float64]) -> None:
        """Add a chunk of samples (copied: a view would keep a whole block alive)."""
        self.size += int(stamps.size)
        if self.spools is None and self.size * 8 >= self.spill_bytes:
            self.spools = (Spool(np.int64), Spool(np.float64), Spool(np.float64))
            lists: tuple[list[NDArray[Any]], ...] = (self.stamps, self.theta, self.s)
            for spool, chunks in zip(self.spools, lists):
                for chunk in chunks:
                    spool.append(chunk)
                chunks.clear()
        if self.spools is None:
            self.stamps.append(stamps.copy())
            self.theta.append(np.array(theta, dtype=float))
            self.s.append(np.array(s, dtype=float))
        else:
            for spool, chunk in zip(self.spools, (stamps, theta, s)):
                spool.append(chunk)

    def columns(self) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """(stamps, theta, s) of every sample received, in arrival order."""
        self.flush()
        if self.spools is not None:
            st, th, pr = (spool.column() for spool in self.spools)
            self.spools = None
            return st, th, pr
        return _cat(self.stamps, np.int64), _cat(self.theta, float), _cat(self.s, float)


def sample_joints(params: dict[str, Any]) -> tuple[str, str]:
    """(angle joint, lift joint) names from the parameters ``angle_joint`` and
    ``lift_joint`` (default ``camshaft``, ``probe``); InputError for an empty name or
    the same name twice."""
    names = (params.get('angle_joint', CAMSHAFT), params.get('lift_joint', PROBE))
    for key, name in zip(('angle_joint', 'lift_joint'), names):
        if not isinstance(name, str) or not name:
            raise InputError(f'metrology.{key}', name, 'a joint name (non-empty string)')
    if names[0] == names[1]:
        raise InputError('metrology.lift_joint', names[1],
                         f'a joint other than the angle joint {names[0]!r}')
    return names[0], names[1]


def joint_positions(msg: Any, joints: tuple[str, str] = (CAMSHAFT, PROBE),
                    ) -> tuple[float, float]:
    """(theta [rad], s [m]) of a JointState message, looked up by joint name
    (``joints``: the angle and lift joints).

    Raises InputError when a joint is missing or the arrays do not match.
    """
    names = list(msg.name)
    pos = msg.position
    try:
        i, j = names.index(joints[0]), names.index(joints[1])
    except ValueError:
        raise InputError('joint_states.name', names,
                         f'joint names containing {joints[0]!r} and {joints[1]!r}') from None
    if len(pos) < len(names):
        raise InputError('joint_states.position', f'{len(pos)} values',
                         f'one position per name ({len(names)})')
    return float(pos[i]), float(pos[j])


def stamp_of(msg: Any, fallback_ns: int) -> int:
    """Header stamp [ns] of a message, or ``fallback_ns`` when the stamp is zero."""
    st = msg.header.stamp
    ns = int(st.sec) * 1_000_000_000 + int(st.nanosec)
    return ns if ns else int(fallback_ns)


class FeatureAssembler:
    """Splits a sample stream into features; returns finished ones as they end. The
    columns of a feature of more than ``spill_bytes`` a column go to temporary files
    as they arrive and come back memory-mapped (``spill``)."""

    def __init__(self, spill_bytes: int = SPILL_BYTES) -> None:
        self._open: _OpenFeature | None = None
        self.spill_bytes = spill_bytes

    @property
    def current(self) -> str | None:
        """Id of the feature being received, if any."""
        return self._open.feature_id if self._open else None

    @property
    def last_rx_ns(self) -> int:
        """Receive time [ns] of the last sample of the open feature (0 if none)."""
        return self._open.last_rx_ns if self._open else 0

    def add(self, feature_id: str, stamp_ns: int, theta: float, s: float,
            rx_ns: int) -> list[FeatureSamples]:
        """Add one sample; returns the feature it closed, if a new one started."""
        done = []
        if self._open is None or self._open.feature_id != feature_id:
            done = self.close()
            self._open = _OpenFeature(feature_id, self.spill_bytes)
        self._open.pending.append((stamp_ns, theta, s))
        self._open.last_rx_ns = rx_ns
        return done

    def add_bulk(self, frame_ids: Sequence[str] | ArrayLike, stamp_ns: ArrayLike,
                 theta: ArrayLike, s: ArrayLike, rx_ns: int) -> list[FeatureSamples]:
        """Add many samples at once (fast path); returns the features they closed."""
        ids = np.asarray(frame_ids)
        st = np.asarray(stamp_ns, dtype=np.int64)
        th = np.asarray(theta, dtype=float)
        pr = np.asarray(s, dtype=float)
        n = ids.size
        if not (st.size == th.size == pr.size == n):
            raise InputError('handle_samples', f'sizes {n}, {st.size}, {th.size}, {pr.size}',
                             'frame_ids, stamp_ns, theta and s of equal length')
        done: list[FeatureSamples] = []
        if n == 0:
            return done
        cuts = np.flatnonzero(ids[1:] != ids[:-1]) + 1
        bounds = np.concatenate(([0], cuts, [n]))
        for a, b in zip(bounds[:-1], bounds[1:]):
            fid = str(ids[a])
            if self._open is None or self._open.feature_id != fid:
                done += self.close()
                self._open = _OpenFeature(fid, self.spill_bytes)
            self._open.flush()
            self._open.append(st[a:b], th[a:b], pr[a:b])
            self._open.last_rx_ns = rx_ns
        return done

    def close(self, feature_id: str | None = None) -> list[FeatureSamples]:
        """End the open feature (only if its id is ``feature_id``, when given)."""
        if self._open is None:
            return []
        if feature_id is not None and feature_id != self._open.feature_id:
            return []
        feat = self._open
        self._open = None
        return [clean_feature(feat.feature_id, *feat.columns())]


def _cat(chunks: list[NDArray[Any]], dtype: Any) -> NDArray[Any]:
    """The chunks as one array of ``dtype``; the list is emptied (each chunk freed as
    soon as the whole is made: one copy of the samples at a time)."""
    out = np.concatenate(chunks).astype(dtype, copy=False) if chunks else np.zeros(0, dtype)
    chunks.clear()
    return out


def unwrapped_blocks(theta: NDArray[np.float64], block: int = 1 << 16,
                     ) -> Iterator[NDArray[np.float64]]:
    """``numpy.unwrap(theta)`` [rad] a block at a time (the same values: the same
    corrections, summed in the same order), without its full-size temporaries."""
    carry = 0.0
    for k in range(0, theta.size, block):
        p = theta[max(k - 1, 0):k + block]
        dd = np.diff(p)
        ddmod = np.mod(dd + np.pi, 2 * np.pi) - np.pi
        ddmod[(ddmod == -np.pi) & (dd > 0)] = np.pi
        correct = ddmod - dd
        correct[np.abs(dd) < np.pi] = 0.0
        sums = np.cumsum(np.concatenate(([carry], correct)))
        if k == 0:
            out = p.copy()
            out[1:] += sums[1:]
        else:
            out = p[1:] + sums[1:]
        carry = float(sums[-1])
        yield out
        release(theta)   # a spilled column: one block resident at a time


def unwrapped_span(theta: NDArray[np.float64]) -> float:
    """``numpy.ptp(numpy.unwrap(theta))`` [rad] (``unwrapped_blocks``)."""
    lo, hi = np.inf, -np.inf
    for part in unwrapped_blocks(theta):
        if part.size:
            lo, hi = min(lo, float(part.min())), max(hi, float(part.max()))
    return hi - lo if hi >= lo else 0.0


def clean_feature(feature_id: str, stamp_ns: NDArray[np.int64], theta: NDArray[np.float64],
                  s: NDArray[np.float64]) -> FeatureSamples:
    """Drop NaN/inf samples and exact duplicates, sort by stamp; count what was dropped.
    Spilled columns (``spill.Spool``) are read a block at a time and stay spilled
    (unless the stamps are out of order: then they are sorted in memory)."""
    received = int(theta.size)
    ok = np.empty(received, bool)
    for a, b in walk(received, theta, s):
        np.isfinite(theta[a:b], out=ok[a:b])
        ok[a:b] &= np.isfinite(s[a:b])
    nan_dropped = int(received - np.count_nonzero(ok))
    st, th, pr = (stamp_ns, theta, s) if nan_dropped == 0 else \
        tuple(_kept(col, ok) for col in (stamp_ns, theta, s))
    del ok
    dup = 0
    if not _increasing(st):
        # not in strictly increasing stamp order (the usual case needs no copy)
        order = np.lexsort((pr, th, st))
        st, th, pr = st[order], th[order], pr[order]
        del order
        same = (st[1:] == st[:-1]) & (th[1:] == th[:-1]) & (pr[1:] == pr[:-1])
        keep = np.concatenate(([True], ~same))
        dup = int(st.size - np.count_nonzero(keep))
        if dup:
            st, th, pr = st[keep], th[keep], pr[keep]
    revs = float(unwrapped_span(th) / (2 * np.pi)) if th.size > 1 else 0.0
    release(st, th, pr)
    return FeatureSamples(feature_id, th, pr, st, received, nan_dropped, dup, revs)


def _kept(column: NDArray[Any], ok: NDArray[np.bool_]) -> NDArray[Any]:
    """``column[ok]``; a spilled column stays spilled (written a block at a time)."""
    if not isinstance(column, np.memmap):
        return column[ok]
    spool = Spool(column.dtype)
    for a, b in walk(column.size, column):
        spool.append(column[a:b][ok[a:b]])
    return spool.column()


def _increasing(stamps: NDArray[np.int64]) -> bool:
    """True if the stamps increase strictly (checked a block at a time)."""
    for a, b in walk(stamps.size - 1, stamps):
        if not bool(np.all(stamps[a + 1:b + 1] > stamps[a:b])):
            return False
    return True


#: largest plausible probe span over one feature [m] (a cam lift of 250 mm)
MAX_PROBE_SPAN_M = 0.25


def probe_units_problem(fs: FeatureSamples) -> str | None:
    """Why the probe readings [m] cannot be a cam lift (a span above
    ``MAX_PROBE_SPAN_M``, naming the unit they look like), or None."""
    if fs.s.size < 2:
        return None
    lo, hi = np.inf, -np.inf   # a block at a time: a spilled column gives back its pages
    for a, b in walk(fs.s.size, fs.s):
        lo, hi = min(lo, float(np.min(fs.s[a:b]))), max(hi, float(np.max(fs.s[a:b])))
    span = hi - lo
    if span <= MAX_PROBE_SPAN_M:
        return None
    slip = unit_slip(span, MAX_PROBE_SPAN_M, floor=2e-4)
    if slip is not None:
        return (f'the probe readings span {span:.6g} m, not a cam lift; they look like '
                f'{slip[0]} ({span * slip[1] * 1e3:.4g} mm): the probe joint position must '
                'be in metres')
    return f'the probe readings span {span:.6g} m, not a cam lift (metres expected)'


def encoder_units_hint(fs: FeatureSamples) -> str:
    """A hint for a failed feature whose camshaft angles span a whole number of 360s (an
    encoder in degrees; radians are expected), or ''."""
    if fs.theta.size < 2:
        return ''
    span = float(np.ptp(fs.theta))
    turns = span / 360.0
    if span > 100.0 and round(turns) >= 1 and abs(turns - round(turns)) < 0.02 * turns:
        return (f'; the camshaft angles span {span:.1f} = {round(turns)} x 360: they look '
                'like degrees (the camshaft joint position must be in radians)')
    return ''

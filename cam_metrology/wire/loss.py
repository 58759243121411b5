"""Lost-message accounting from DDS publication sequence numbers (pure Python, no rclpy).

Every DDS writer numbers its samples 1, 2, 3, ... (``publication_sequence_number`` of
rclpy's MessageInfo). A subscriber that sees 41 after 37 has lost 38, 39 and 40: the
writer's or its own keep-last history overwrote them before they were taken. That is
the only way a reliable topic loses data, so counting the holes counts the loss
exactly, with no help from the publisher.

* ``SequenceLoss``: one topic. ``add(seqs)`` takes the sequence numbers in the order
  received and returns the holes it found (position in the batch, samples missing just
  before it). Numbers received before the first one are counted apart
  (``missed_at_start``): samples published before this subscriber got anything, e.g.
  a recorder started after the stream began, are not in its output either, so they are
  reported too, but as what they are.
* Several publishers on one topic: rclpy 7.1.6 gives no publisher id in MessageInfo,
  so each number is given to the stream (publisher) whose last number is the largest
  one below it; a number with no such stream starts a new stream (a second publisher,
  or one restarted). Without loss this is exact whatever the interleaving (the true
  predecessor ``s - 1`` is always the best fit); with loss and several publishers the
  split between them can be off, the total rarely. One publisher per topic (the
  bench) is exact.
* Blocks (``/bench/joint_trajectory``: many samples per message): the holes count
  lost blocks; ``SequenceLoss(blocks=True)`` also counts the samples of the blocks
  received (``add_samples``) and gives the samples lost as the lost blocks times the
  mean block size received (``samples_lost``, said "about N samples").
* ``FeatureLoss``: the holes attributed to the features (JointState ``frame_id``) of
  the samples around them; a hole between two features is charged to both (its
  samples belonged to one or the other), so a feature computed on partial data is
  always marked.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np

from cam_metrology.wire.topics import JOINT_STATES

OK, WARN, ERROR = 0, 1, 2   # diagnostic_msgs/DiagnosticStatus levels


@dataclass
class SequenceLoss:
    """Received, lost and missed-at-start counts of one topic."""

    topic: str
    received: int = 0
    lost: int = 0                 # holes after the first sample of a stream
    missed_at_start: int = 0      # numbers below the first one received of each stream
    streams: list[int] = field(default_factory=list)   # last number of each stream
    blocks: bool = False          # a message holds many samples (a block)
    block_samples: int = 0        # samples in the blocks received (blocks only)

    def add_samples(self, n: int) -> None:
        """Count ``n`` samples received in blocks (blocks only)."""
        self.block_samples += int(n)

    @property
    def samples_per_message(self) -> float:
        """Mean samples per message received (1 for one sample per message)."""
        if not self.blocks or not self.received:
            return 1.0
        return self.block_samples / self.received

    @property
    def samples_lost(self) -> int:
        """Samples lost: the lost messages (blocks: times the mean block size)."""
        return int(round(self.lost * self.samples_per_message))

    @property
    def samples_missed_at_start(self) -> int:
        """Samples published before the first one received (blocks: estimated)."""
        return int(round(self.missed_at_start * self.samples_per_message))

    def add(self, seqs: Iterable[int] | np.ndarray) -> list[tuple[int, int]]:
        """Account for ``seqs`` (in the order received); returns [(index in seqs,
        samples lost just before it)] for every hole, start gaps included."""
        arr = np.asarray(seqs if isinstance(seqs, np.ndarray) else list(seqs), dtype=np.int64)
        if arr.size == 0:
            return []
        self.received += int(arr.size)
        if len(self.streams) == 1 and arr[0] > self.streams[0] and (
                arr.size == 1 or bool(np.all(arr[1:] > arr[:-1]))):
            # one publisher, in order: vectorised
            gaps = np.diff(np.concatenate(([self.streams[0]], arr))) - 1
            self.streams[0] = int(arr[-1])
            idx = np.nonzero(gaps)[0]
            self.lost += int(gaps[idx].sum())
            return [(int(i), int(gaps[i])) for i in idx]
        holes: list[tuple[int, int]] = []
        for i, s in enumerate(arr.tolist()):
            best = -1
            for k, last in enumerate(self.streams):
                if last < s and (best < 0 or last > self.streams[best]):
                    best = k
            if best < 0:   # a new stream (first publisher, another one, or a restart)
                self.streams.append(s)
                if s > 1:
                    self.missed_at_start += s - 1
                    holes.append((i, s - 1))
                continue
            gap = s - self.streams[best] - 1
            self.streams[best] = s
            if gap:
                self.lost += gap
                holes.append((i, gap))
        return holes

    @property
    def expected(self) -> int:
        """Samples published from the first one received on (received + lost)."""
        return self.received + self.lost

    def summary(self) -> str:
        """One line: 'lost N samples on TOPIC (of M)' or 'no loss on TOPIC (M samples)'."""
        if self.blocks:
            return self._block_summary()
        parts = []
        if self.lost:
            parts.append(f'lost {self.lost} samples on {self.topic} '
                         f'({self.received} of {self.expected} received)')
        if self.missed_at_start:
            parts.append(f'missed {self.missed_at_start} samples on {self.topic} '
                         'published before the first one received')
        return '; '.join(parts) or f'no loss on {self.topic} ({self.received} received)'

    def _block_summary(self) -> str:
        """``summary`` of a block topic: blocks and (estimated) samples."""
        parts = []
        if self.lost:
            parts.append(f'lost {self.lost} blocks (about {self.samples_lost} samples) on '
                         f'{self.topic} ({self.received} of {self.expected} blocks received'
                         f', {self.block_samples} samples)')
        if self.missed_at_start:
            parts.append(f'missed {self.missed_at_start} blocks (about '
                         f'{self.samples_missed_at_start} samples) on {self.topic} '
                         'published before the first one received')
        return '; '.join(parts) or (f'no loss on {self.topic} ({self.received} blocks, '
                                    f'{self.block_samples} samples received)')

    @property
    def level(self) -> int:
        """ERROR when samples were lost in the stream, WARN when only the start was
        missed, OK otherwise."""
        return ERROR if self.lost else WARN if self.missed_at_start else OK


@dataclass
class FeatureLoss:
    """Samples lost per feature (frame_id) of a sample stream."""

    lost: dict[str, int] = field(default_factory=dict)
    seen: set[str] = field(default_factory=set)
    completed: set[str] = field(default_factory=set)   # a result was published
    parts: dict[str, int] = field(default_factory=dict)   # > 1: the feature was split
    _last_feature: str | None = None

    def add(self, frame_ids: Sequence[Any], holes: Sequence[tuple[int, int]]) -> set[str]:
        """Charge each hole (index into ``frame_ids``, count) to the feature of the
        sample after it and, when different, to the feature of the sample before it;
        returns the features charged."""
        charged: set[str] = set()
        for i, n in holes:
            after = str(frame_ids[i])
            before = str(frame_ids[i - 1]) if i > 0 else self._last_feature
            for fid in {after, before}:
                if fid is None:
                    continue
                self.lost[fid] = self.lost.get(fid, 0) + n
                charged.add(fid)
        if len(frame_ids):
            first, last = str(frame_ids[0]), str(frame_ids[-1])
            fids = {first} if first == last else {str(f) for f in np.unique(
                np.asarray(frame_ids))}
            for fid in fids & self.completed:   # samples of a feature already measured
                self.parts[fid] = self.parts.get(fid, 1) + 1
                self.completed.discard(fid)
                charged.add(fid)
            self.seen.update(fids)
            self._last_feature = last
        return charged

    def result_published(self, feature_id: str) -> None:
        """A result of ``feature_id`` went out: more samples of it mean a split."""
        if feature_id in self.seen:
            self.completed.add(feature_id)

    def problem(self, feature_id: str, topic: str = JOINT_STATES) -> str:
        """Why a feature's result rests on partial data ('' if it does not)."""
        out = []
        if self.of(feature_id):
            out.append(f'lost {self.of(feature_id)} samples on {topic}')
        if self.parts.get(feature_id, 1) > 1:
            out.append(f'received in {self.parts[feature_id]} parts (a pause in the stream '
                       'longer than the idle timeout ended it early; each part was analysed '
                       'alone)')
        return '; '.join(out)

    def of(self, feature_id: str) -> int:
        """Samples lost in or next to ``feature_id`` (0: complete)."""
        return self.lost.get(feature_id, 0)


def loss_values(losses: Iterable[SequenceLoss]) -> dict[str, str]:
    """DiagnosticStatus key/values: received/TOPIC, lost/TOPIC, missed_at_start/TOPIC."""
    out: dict[str, str] = {}
    for loss in losses:
        out[f'received{loss.topic}'] = str(loss.received)
        out[f'lost{loss.topic}'] = str(loss.lost)
        out[f'missed_at_start{loss.topic}'] = str(loss.missed_at_start)
        if loss.blocks:
            out[f'samples_received{loss.topic}'] = str(loss.block_samples)
            out[f'samples_lost{loss.topic}'] = str(loss.samples_lost)
    return out


def loss_status(losses: Sequence[SequenceLoss], extra: str = '') -> tuple[int, str]:
    """(level, message) of a node's input: the worst level; the message lists every
    topic with loss ('lost N samples on TOPIC ...'), or 'no loss (N messages)'."""
    bad = [x for x in losses if x.level != OK]
    level = max((x.level for x in losses), default=OK)
    if bad:
        msg = '; '.join(x.summary() for x in bad)
    else:
        msg = f'no loss ({sum(x.received for x in losses)} messages received'
        blocks = [x for x in losses if x.blocks and x.received]
        msg += ''.join(f', {x.block_samples} samples in {x.received} blocks on {x.topic}'
                       for x in blocks) + ')'
    return level, msg + (f'; {extra}' if extra else '')


def mark_partial(outputs: Sequence[Any], features: FeatureLoss, losses: Sequence[SequenceLoss],
                 topic: str = JOINT_STATES) -> list[Any]:
    """Outputs of a core with the input loss made visible (``cam_metrology.cores.outputs``):

    * a Status named after a feature with lost samples, or one split in parts (its
      samples came again after its result: a pause longer than the idle timeout ended
      it early): level at least WARN, message prefixed ``partial data: lost N samples
      on TOPIC`` / ``received in K parts ...``, values ``samples_lost`` = N, ``parts``
      and ``partial`` = True (N counts the holes in the feature or next to it); a
      Status of a complete feature gets ``samples_lost`` = 0;
    * a JSON report (TextOutput on ``*/report`` holding a dict with ``features``):
      ``samples_lost``, ``partial`` (and ``partial_reason``) per feature, and ``input`` =
      received, lost and
      missed-at-start counts per topic with the total ``samples_lost``.
    """
    import dataclasses
    import json

    from cam_metrology.cores.outputs import StatusOutput, TextOutput
    out: list[Any] = []
    for o in outputs:
        if isinstance(o, StatusOutput):
            statuses = []
            for st in o.statuses:
                if st.name not in features.seen:
                    statuses.append(st)
                    continue
                why = features.problem(st.name, topic)
                values = {**st.values, 'samples_lost': str(features.of(st.name)),
                          'partial': str(bool(why))}
                if features.parts.get(st.name, 1) > 1:
                    values['parts'] = str(features.parts[st.name])
                if why:
                    st = dataclasses.replace(
                        st, level=max(int(st.level), WARN), values=values,
                        message=f'partial data: {why}; {st.message}')
                else:
                    st = dataclasses.replace(st, values=values)
                statuses.append(st)
            o = dataclasses.replace(o, statuses=tuple(statuses))
        elif isinstance(o, TextOutput) and o.topic.endswith('/report'):
            try:
                doc = json.loads(o.text)
            except ValueError:
                doc = None
            if isinstance(doc, dict) and isinstance(doc.get('features'), dict):
                for fid, entry in doc['features'].items():
                    if isinstance(entry, dict):
                        why = features.problem(fid, topic)
                        entry['samples_lost'] = features.of(fid)
                        entry['partial'] = bool(why)
                        if why:
                            entry['partial_reason'] = why
                doc['input'] = {
                    'samples_lost': sum(x.samples_lost for x in losses),
                    'missed_at_start': sum(x.samples_missed_at_start for x in losses),
                    'topics': {x.topic: _topic_counts(x) for x in losses}}
                o = dataclasses.replace(o, text=json.dumps(doc, indent=1))
        out.append(o)
    return out


def _topic_counts(loss: SequenceLoss) -> dict[str, int]:
    """Report counts of one topic: messages received, lost and missed at the start;
    for blocks also the samples received and (estimated) lost."""
    out = {'received': loss.received, 'lost': loss.lost,
           'missed_at_start': loss.missed_at_start}
    if loss.blocks:
        out.update(samples_received=loss.block_samples, samples_lost=loss.samples_lost)
    return out

"""`cam-bench bag info BAG`: topics, types, counts, QoS, the scene and the samples per
feature of a bag (streamed: memory does not grow with the bag).
"""
from __future__ import annotations

import argparse
from typing import Any

from cam_metrology.wire.topics import JOINT_TRAJECTORY, SAMPLE_TOPICS


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``info`` to the ``bag`` group."""
    p = sub.add_parser(
        'info', help='topics, types, counts, QoS and the features of a bag',
        description='Print every topic with its type, message count and durability, '
                    'the scene\'s camshaft id and the samples per feature.')
    p.add_argument('bag', metavar='BAG', help='rosbag2 directory')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench bag info``: summarise a bag (0)."""
    from cam_metrology import bagio
    from cam_metrology.wire.topics import SCENE as SCENE_TOPIC

    topics = bagio.bag_topics(args.bag)
    qos = bagio.topic_qos_yaml(args.bag)
    print(f'{args.bag}:')
    for topic, (msgtype, count) in sorted(topics.items()):
        latched = 'transient_local' in qos.get(topic, '')
        print(f'  {topic:28s} {msgtype:40s} {count:9d}' + ('  latched' if latched else ''))
    if SCENE_TOPIC in topics:
        from cam_metrology.scene.recorded import bag_scenes
        for sc in bag_scenes(args.bag):
            if sc.scene is None:
                print(f'scene: invalid: {sc.error}')
                continue
            scene = sc.scene
            print(f'scene: {scene.camshaft_id or "(no id)"}, {len(scene.lobes)} lobes, '
                  f'{_datum_words(scene)}, '
                  f'direction {scene.direction:+d} (log time {sc.stamp_ns / 1e9:.6f} s)')
    if any(t in topics for t in SAMPLE_TOPICS):
        _print_samples(args.bag)
    return 0


def _print_samples(bag: str) -> None:
    """The samples of a bag, per feature, and the unusable ones (streamed: memory
    does not grow with the bag)."""
    import numpy as np

    from cam_metrology import bagio

    summary = bagio.JointSummary()
    counts: dict[str, int] = {}
    first = last = None
    blocks = bagio.bag_topics(bag).get(JOINT_TRAJECTORY, ('', 0))[1]   # messages
    for block in bagio.iter_joint_states(bag):
        summary.add(block)
        if len(block):
            lo, hi = int(block.log_ns.min()), int(block.log_ns.max())
            first = lo if first is None else min(first, lo)
            last = hi if last is None else max(last, hi)
        ids, n = np.unique(block.frame_id, return_counts=True)
        for fid, k in zip(ids.tolist(), n.tolist()):
            counts[str(fid)] = counts.get(str(fid), 0) + int(k)
    if first is not None and last is not None:
        inside = f' (in {blocks} blocks on {JOINT_TRAJECTORY})' if blocks else ''
        print(f'samples: {summary.count}{inside} over {(last - first) / 1e9:.3f} s; '
              f'joints {list(summary.names)}')
    for fid in summary.features:
        print(f'  {fid}: {counts.get(fid, 0)} samples')
    for issue in summary.issues:
        print(f'unusable samples: {issue.text(summary.count)}')


def _datum_words(scene: Any) -> str:
    """'a dowel pin', 'a keyway' or 'no dowel pin' (bag info)."""
    if getattr(scene, 'keyway', None) is not None:
        return 'a keyway'
    return 'a dowel pin' if scene.dowel_pin is not None else 'no dowel pin'

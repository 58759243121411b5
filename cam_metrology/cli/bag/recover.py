"""`cam-bench bag recover SRC DST`: save what is intact of an interrupted or damaged
recording into a new, closed bag.
"""
from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``recover`` to the ``bag`` group."""
    p = sub.add_parser(
        'recover', help='copy the intact part of an interrupted or damaged recording',
        description='A recording whose writer never closed has no metadata.yaml and no '
                    'MCAP footer; a copied or stored bag may have damaged chunks. This '
                    'copies every intact record (chunks that pass `bag check`) into a '
                    'new, closed bag and lists what was dropped.')
    p.add_argument('src', metavar='SRC', help='bag directory or .mcap file')
    p.add_argument('dst', metavar='DST', help='new bag directory (must not exist)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench bag recover``: copy what is intact of an interrupted
    or damaged recording into a new bag (0)."""
    from cam_metrology import bagio
    from cam_metrology.bagio.check import describe

    from cam_metrology.inputs.files import atomic_dir
    with atomic_dir(args.dst, 'DST') as tmp:   # a whole recovered bag or nothing
        counts = bagio.recover_bag(args.src, tmp)
    print(f'recovered into {args.dst}:')
    for topic, n in sorted(counts.items()):
        print(f'  {topic}: {n}')
    for d in counts.damaged:   # an empty range: nothing dropped, only the end missing
        print(f'{"dropped" if d.end > d.start else "note"}: {describe(d)}')
    return 0

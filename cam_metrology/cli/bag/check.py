"""`cam-bench bag check BAG`: verify the MCAP chunks of a bag (CRC-32, sizes, framing)
and name the damaged ranges.
"""
from __future__ import annotations

import argparse
import sys


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``check`` to the ``bag`` group."""
    p = sub.add_parser(
        'check', help='verify the MCAP chunks of a bag (CRC-32, sizes, framing)',
        description='Read every chunk of every MCAP file of the bag: decompress it, '
                    'compare its size and its CRC-32 (where the writer stored one) and '
                    'check the records inside. Prints each damaged range (file bytes, log '
                    'times, messages per topic, reason); exit 0 intact, 1 damaged.')
    p.add_argument('bag', metavar='BAG', help='rosbag2 directory or .mcap file')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench bag check``: verify the MCAP files of a bag; 0 intact,
    1 damaged, 2 for bad input."""
    from pathlib import Path

    from cam_design.errors import InputError
    from cam_metrology.bagio.check import describe, scan_bag

    if not Path(args.bag).exists():
        raise InputError('BAG', args.bag, 'an existing rosbag2 directory or .mcap file')
    scans = scan_bag(args.bag)
    if not scans:
        raise InputError('BAG', args.bag, 'a bag with MCAP storage (.mcap files)')
    damaged = 0
    for scan in scans:
        crc = (f'{scan.crc_chunks} with a CRC-32' if scan.crc_chunks
               else 'none with a CRC-32: payload damage in uncompressed chunks is '
                    'undetectable')
        print(f'{scan.file}: {scan.chunks} chunks ({crc})')
        for d in scan.damaged:
            print(f'  damaged: {describe(d)}')
        damaged += len(scan.damaged)
    if damaged:
        print(f'cam-bench bag check: {damaged} damaged range(s) in {args.bag}; '
              '`cam-bench bag recover` copies what is intact', file=sys.stderr)
        return 1
    print('intact')
    return 0

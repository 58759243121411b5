"""Analyse many bags at once on a Dask cluster: one table row per bag x feature.

Each bag goes through exactly what ``cam-bench analyze`` runs (``cli.golden.
analyze_report``), on a Dask worker: a local cluster by default, or an existing
scheduler (``tcp://host:8786``) with the same code path. A bag that cannot be analysed
becomes a row with ``status = 'failed'`` and the reason: one bad bag never stops the
batch. Rows carry provenance (the bag's SHA-256 over its files, camshaft id, cam-bench
version, bag start time), so a table can be resumed: bags already in it (same path and
hash) are skipped unless ``redo``. A bag whose hash equals an earlier one in the same
batch is a duplicate: it gets a row that says so and is not analysed twice.
"""
from __future__ import annotations

import glob
import hashlib
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

from cam_design.errors import InputError

#: columns every row has, in this order (then the report fields, sorted)
BASE_COLUMNS = ('bag', 'bag_sha256', 'bag_start_utc_ns', 'camshaft_id', 'feature', 'kind',
                'status', 'reason', 'cam_bench_version', 'analyzed_utc')


def cam_bench_version() -> str:
    """The installed cam-bench version (``unknown`` outside an install)."""
    try:
        from importlib.metadata import version
        return version('cam_metrology')
    except Exception:  # noqa: BLE001 -- any metadata problem: say unknown
        return 'unknown'


#: columns of a gauge R&R study, from the scene keys of the same names (report 'study')
STUDY_COLUMNS = ('part_id', 'operator', 'trial')


def find_bags(inputs: Iterable[str]) -> list[Path]:
    """Bags named by ``inputs``: a bag folder, a folder searched for bags (any depth: bag
    folders and loose ``.mcap`` files outside them), a glob pattern, or ``@FILE`` with one
    such input per line. Sorted, without repeats."""
    found: list[Path] = []
    for item in inputs:
        if item.startswith('@'):
            listing = Path(item[1:])
            if not listing.is_file():
                raise InputError('INPUTS', item, 'a list file that exists (@FILE)')
            lines = [ln.strip() for ln in listing.read_text(encoding='utf-8').splitlines()]
            found += find_bags([ln for ln in lines if ln and not ln.startswith('#')])
            continue
        matches = [Path(m) for m in sorted(glob.glob(item))] if any(
            c in item for c in '*?[') else [Path(item)]
        if not matches:
            raise InputError('INPUTS', item, 'a bag, a folder of bags or a pattern that '
                             'matches something')
        for m in matches:
            if (m / 'metadata.yaml').is_file() or m.suffix == '.mcap':
                found.append(m)
            elif m.is_dir():
                dirs = sorted(p.parent for p in m.rglob('metadata.yaml'))
                loose = [p for p in sorted(m.rglob('*.mcap'))   # .mcap outside bag folders
                         if not any(d == p.parent or d in p.parents for d in dirs)]
                found += sorted(dirs + loose)
            else:
                found.append(m)          # analysed, and reported as failed with the reason
    out, seen = [], set()
    for p in found:
        key = str(p.resolve())
        if key not in seen:
            seen.add(key)
            out.append(p)
    return out


def bag_sha256(bag: Path) -> str:
    """SHA-256 over the bag's files (name and content, in name order)."""
    h = hashlib.sha256()
    files = sorted(p for p in bag.rglob('*') if p.is_file()) if bag.is_dir() else [bag]
    for f in files:
        h.update(f.name.encode())
        with open(f, 'rb') as fh:
            for block in iter(lambda: fh.read(1 << 20), b''):
                h.update(block)
    return h.hexdigest()


def _start_ns(bag: Path) -> int | None:
    meta = bag / 'metadata.yaml'
    if not meta.is_file():
        return None
    try:
        import yaml
        info = yaml.safe_load(meta.read_text(encoding='utf-8'))['rosbag2_bagfile_information']
        return int(info['starting_time']['nanoseconds_since_epoch'])
    except Exception:  # noqa: BLE001 -- a damaged metadata file: no start time
        return None


def _flatten(prefix: str, value: Any, out: dict[str, Any]) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flatten(f'{prefix}.{k}' if prefix else str(k), v, out)
    elif isinstance(value, (list, tuple)):
        out[prefix] = json.dumps(value)
    else:
        out[prefix] = value


def rows_of_report(bag: str, sha: str, report: dict[str, Any], start_ns: int | None,
                   ) -> list[dict[str, Any]]:
    """One row per feature of an ``analyze`` report (nested fields as ``a.b`` columns)."""
    common = {'bag': bag, 'bag_sha256': sha, 'bag_start_utc_ns': start_ns,
              'camshaft_id': str(report.get('camshaft_id', '')),
              'cam_bench_version': cam_bench_version(),
              **{k: (report.get('study') or {}).get(k) for k in STUDY_COLUMNS},
              'analyzed_utc': time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}
    rows = []
    for fid, feat in (report.get('features') or {}).items():
        row = dict(common, feature=fid, kind=feat.get('kind'), status=feat.get('status'),
                   reason=feat.get('reason'))
        fields: dict[str, Any] = {}
        _flatten('', {k: v for k, v in feat.items()
                      if k not in ('kind', 'status', 'reason')}, fields)
        row.update(fields)
        rows.append(row)
    if not rows:
        rows.append(dict(common, feature=None, kind=None, status='failed',
                         reason='the report has no feature'))
    return rows


def analyse_bag(bag: str, all_cores: bool = False) -> list[dict[str, Any]]:
    """Rows of one bag (runs on a worker); a failure is a row, never an exception. The
    report comes from the metrology core; ``all_cores`` runs reconstruction and dynamics
    too (as ``analyze`` does by default), which only adds their skip notes here."""
    os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')
    path = Path(bag)
    try:
        sha = bag_sha256(path) if path.exists() else ''
    except OSError as exc:
        sha = ''
        return [_failed(bag, sha, f'unreadable: {exc.strerror}')]
    try:
        from cam_metrology.offline.analyze import analyze_report
        report = analyze_report(path, only_metrology=not all_cores)
    except Exception as exc:  # noqa: BLE001 -- every failure is reported per bag
        return [_failed(bag, sha, str(exc) or type(exc).__name__)]
    return rows_of_report(bag, sha, report, _start_ns(path))


def _failed(bag: str, sha: str, reason: str) -> dict[str, Any]:
    return {'bag': bag, 'bag_sha256': sha, 'bag_start_utc_ns': None, 'camshaft_id': None,
            'feature': None, 'kind': None, 'status': 'failed', 'reason': reason,
            'cam_bench_version': cam_bench_version(),
            'analyzed_utc': time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}


@dataclass
class BatchSummary:
    """What a batch did."""

    bags: int
    analysed: int
    skipped: int
    duplicates: int
    failed: int
    rows: int
    seconds: float


def read_table(path: Path) -> list[dict[str, Any]]:
    """Rows of an existing results table (Parquet), or [] when there is none."""
    if not path.exists():
        return []
    import pyarrow.parquet as pq
    try:
        return pq.read_table(path).to_pylist()
    except Exception as exc:  # noqa: BLE001 -- not a Parquet file: say so, write nothing
        raise InputError('--out', str(path), f'a Parquet results table to extend ({exc})') \
            from None


def write_table(rows: list[dict[str, Any]], parquet: Path, csv: Path | None = None) -> None:
    """Write the rows to Parquet (and CSV), each to a temporary name first and renamed
    when complete, so an interrupted write never leaves a table that looks whole."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    names = list(BASE_COLUMNS) + sorted({k for r in rows for k in r} - set(BASE_COLUMNS))
    columns = {}
    for n in names:
        vals = [r.get(n) for r in rows]
        kinds = {type(v) for v in vals if v is not None}
        if kinds <= {int, float} and float in kinds:
            vals = [None if v is None else float(v) for v in vals]
        elif len(kinds) > 1:
            vals = [None if v is None else str(v) for v in vals]
        columns[n] = vals
    table = pa.table(columns)
    for target, writer in ((parquet, lambda t, p: pq.write_table(t, p)),
                           (csv, lambda t, p: pacsv.write_csv(t, p))):
        if target is None:
            continue
        tmp = target.with_name(f'.{target.name}.partial')
        try:
            writer(table, str(tmp))
            tmp.replace(target)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise InputError('--out' if target == parquet else '--csv', str(target),
                             f'a writable path ({exc.strerror})') from None


def run_batch(bags: list[Path], out: Path, *, csv: Path | None = None,
              scheduler: str | None = None, workers: int = 2, redo: bool = False,
              progress: Callable[[str], None] | None = None,
              connect_timeout_s: float = 10.0, all_cores: bool = False) -> BatchSummary:
    """Analyse ``bags`` on Dask and write the table (see the module docstring)."""
    from dask.distributed import Client, LocalCluster, as_completed

    say = progress or (lambda m: None)
    t0 = time.perf_counter()
    old = read_table(out)
    done = set() if redo else {(r['bag'], r['bag_sha256']) for r in old
                               if r.get('bag_sha256')}
    hashes: dict[str, str] = {} if redo else {
        r['bag_sha256']: r['bag'] for r in old
        if r.get('bag_sha256') and r['status'] != 'duplicate'}
    todo, skipped, dup_rows = [], 0, []
    for bag in bags:
        name = str(bag)
        try:
            sha = bag_sha256(bag) if bag.exists() else ''
        except OSError:
            sha = ''
        if (name, sha) in done and sha:
            skipped += 1
            continue
        if sha and sha in hashes and hashes[sha] != name:
            dup_rows.append(dict(_failed(name, sha, f'duplicate of {hashes[sha]} (same '
                                 'files): not analysed twice'), status='duplicate'))
            continue
        if sha:
            hashes[sha] = name
        todo.append(name)
    again = set(todo) | {r['bag'] for r in dup_rows}
    rows: list[dict[str, Any]] = [r for r in old if r['bag'] not in again] + dup_rows
    if todo:
        cluster = None
        try:
            if scheduler:
                try:
                    client = Client(scheduler, timeout=f'{connect_timeout_s}s')
                except (OSError, TimeoutError) as exc:
                    raise InputError('--scheduler', scheduler, f'a reachable Dask scheduler '
                                     f'({type(exc).__name__}: {exc})') from None
            else:
                cluster = LocalCluster(n_workers=max(1, workers), threads_per_worker=1,
                                       processes=True, dashboard_address=None)
                client = Client(cluster)
            try:
                futures = client.map(analyse_bag, todo, all_cores=all_cores, pure=False)
                for i, fut in enumerate(as_completed(futures), 1):
                    part = fut.result()
                    rows += part
                    state = 'failed: ' + str(part[0]['reason']) if part[0]['status'] == \
                        'failed' else f'{len(part)} features'
                    say(f'[{i}/{len(todo)}] {part[0]["bag"]}: {state}')
            finally:
                client.close()
        finally:
            if cluster is not None:
                cluster.close()
    rows.sort(key=lambda r: (str(r.get('bag')), str(r.get('feature'))))
    write_table(rows, out, csv)
    new = [r for r in rows if r['bag'] in set(todo)]
    return BatchSummary(bags=len(bags), analysed=len(todo), skipped=skipped,
                        duplicates=len(dup_rows),
                        failed=len({r['bag'] for r in new if r['status'] == 'failed'}),
                        rows=len(rows), seconds=time.perf_counter() - t0)

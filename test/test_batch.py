"""`cam-bench batch` on a real dask.distributed LocalCluster with two workers.

Truth: every row equals what ``cam-bench analyze`` reports for that bag on its own (same
code path, same machine: equal values); a damaged input becomes a failed row; a copy of a
bag is a duplicate; a second run skips what the table has; an unreachable scheduler is a
one-line error.
"""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from cam_design.errors import InputError
from cam_metrology.offline.batch import find_bags, read_table, run_batch
from cam_metrology.offline.analyze import analyze_report

BAGS = Path(__file__).resolve().parent.parent / 'bags'


@pytest.fixture(scope='module')
def archive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp('archive')
    shutil.copytree(BAGS / 'default_clean', root / 'line1' / 'part_a')
    shutil.copytree(BAGS / 'irregular', root / 'line2' / 'part_b')
    shutil.copytree(BAGS / 'default_clean', root / 'line2' / 'part_c_copy_of_a')
    (root / 'broken.mcap').write_bytes(b'not an mcap file at all')
    return root


@pytest.fixture(scope='module')
def first_run(archive: Path) -> tuple[Path, object]:
    out = archive / 'results.parquet'
    bags = find_bags([str(archive), str(archive / 'broken.mcap')])
    summary = run_batch(bags, out, csv=archive / 'results.csv', workers=2)
    return out, summary


def test_rows_equal_single_bag_analysis(archive: Path, first_run) -> None:
    out, summary = first_run
    assert summary.analysed == 3 and summary.duplicates == 1 and summary.failed == 1
    rows = read_table(out)
    a = str(archive / 'line1' / 'part_a')
    mine = {r['feature']: r for r in rows if r['bag'] == a}
    report = analyze_report(a)
    assert set(mine) == set(report['features'])
    for fid, feat in report['features'].items():
        for key in ('angle_deg', 'angle_std_deg', 'phase_deg', 'phase_error_deg',
                    'samples_used', 'status'):
            if key in feat:
                assert mine[fid][key] == feat[key], (fid, key)
        assert mine[fid]['lift_error_um.rms'] == feat['lift_error_um']['rms']
    assert all(len(r['bag_sha256']) == 64 for r in rows if r['bag'] == a)
    assert (archive / 'results.csv').stat().st_size > 1000


def test_failures_and_duplicates_are_rows(archive: Path, first_run) -> None:
    rows = read_table(first_run[0])
    broken = [r for r in rows if r['bag'].endswith('broken.mcap')]
    assert len(broken) == 1 and broken[0]['status'] == 'failed'
    assert 'MCAP' in broken[0]['reason']
    dup = [r for r in rows if r['status'] == 'duplicate']
    assert len(dup) == 1 and 'duplicate of' in dup[0]['reason']


def test_second_run_skips_what_the_table_has(archive: Path, first_run) -> None:
    out = first_run[0]
    before = read_table(out)
    again = run_batch(find_bags([str(archive / 'line1')]), out, workers=1)
    assert again.analysed == 0 and again.skipped == 1
    assert len(read_table(out)) == len(before)


def test_unreachable_scheduler_is_one_error(archive: Path, tmp_path: Path) -> None:
    with pytest.raises(InputError) as info:
        run_batch(find_bags([str(archive / 'line1')]), tmp_path / 'r.parquet',
                  scheduler='tcp://127.0.0.1:9', connect_timeout_s=1.0)
    assert info.value.key == '--scheduler'


def test_inputs_globs_and_lists(archive: Path, tmp_path: Path) -> None:
    assert [p.name for p in find_bags([str(archive / 'line*' / 'part_*')])] == [
        'part_a', 'part_b', 'part_c_copy_of_a']
    listing = tmp_path / 'list.txt'
    listing.write_text(f'# bags of today\n{archive / "line1" / "part_a"}\n')
    assert [p.name for p in find_bags([f'@{listing}'])] == ['part_a']
    with pytest.raises(InputError):
        find_bags([str(archive / 'nothing_*')])
    with pytest.raises(InputError):
        find_bags([f'@{tmp_path / "missing.txt"}'])


def test_folder_search_finds_loose_mcap_files(tmp_path: Path) -> None:
    """A folder holds bag folders (metadata.yaml + .mcap) and loose .mcap files (as other
    recorders write them): both are found; the .mcap inside a bag folder is not counted
    twice."""
    bag = tmp_path / 'day' / 'part_a'
    bag.mkdir(parents=True)
    (bag / 'metadata.yaml').write_text('rosbag2_bagfile_information: {}\n')
    (bag / 'part_a_0.mcap').write_bytes(b'')
    (tmp_path / 'day' / 'foreign.mcap').write_bytes(b'')
    (tmp_path / 'day' / 'sub').mkdir()
    (tmp_path / 'day' / 'sub' / 'other.mcap').write_bytes(b'')
    found = find_bags([str(tmp_path / 'day')])
    assert [p.relative_to(tmp_path / 'day').as_posix() for p in found] == [
        'foreign.mcap', 'part_a', 'sub/other.mcap']

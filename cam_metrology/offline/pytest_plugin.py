"""pytest over recorded bags: a plugin that installs with cam-bench (entry point ``pytest11``).

What it gives a test suite, with nothing to import:

* option ``--cam-bench-bags DIR``: every bag under DIR (a folder with ``metadata.yaml``)
  becomes one case of each test that asks for the ``cam_bench_bag`` fixture; without the
  option those tests are skipped with a note saying how to run them;
* fixture ``cam_bench_analysis``: a function bag path -> the report dict of
  ``cam-bench analyze`` (the same code path), cached for the whole session, so several
  tests of one bag analyse it once;
* fixture ``cam_bench_report``: the report of the current ``cam_bench_bag``;
* ``cam_metrology.report.golden.assert_report_matches(report, golden, angle_tol_arcsec=...,
  lift_tol_um=...)`` to compare with a golden file written by ``cam-bench golden``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import pytest

OPTION = '--cam-bench-bags'


def pytest_addoption(parser: pytest.Parser) -> None:
    """Register ``--cam-bench-bags DIR``."""
    group = parser.getgroup('cam-bench', 'camshaft bags (cam-bench)')
    group.addoption(OPTION, metavar='DIR', default=None,
                    help='run the tests that use the cam_bench_bag fixture once per bag '
                         '(rosbag2 folder with metadata.yaml) found under DIR')


def find_bags(root: str | Path) -> list[Path]:
    """Every rosbag2 folder (one holding ``metadata.yaml``) at or below ``root``, sorted."""
    root = Path(root)
    if (root / 'metadata.yaml').is_file():
        return [root]
    return sorted(p.parent for p in root.rglob('metadata.yaml'))


def pytest_configure(config: pytest.Config) -> None:
    """Check ``--cam-bench-bags`` once, before collection (a usage error, not a test error)."""
    folder = config.getoption(OPTION, default=None)
    if folder is None:
        return
    if not Path(folder).is_dir():
        raise pytest.UsageError(f'{OPTION}: got {folder!r}; expected a directory of bags')
    if not find_bags(folder):
        raise pytest.UsageError(f'{OPTION}: got {folder!r}; expected at least one bag '
                                '(a folder with metadata.yaml) below it')


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """Parametrise ``cam_bench_bag`` over the bags of ``--cam-bench-bags``."""
    if 'cam_bench_bag' not in metafunc.fixturenames:
        return
    folder = metafunc.config.getoption(OPTION)
    if folder is None:
        metafunc.parametrize('cam_bench_bag', [pytest.param(
            None, marks=pytest.mark.skip(reason=f'no bags given: run pytest with {OPTION} DIR'))])
        return
    bags = find_bags(folder)
    root = Path(folder)
    metafunc.parametrize('cam_bench_bag', bags,
                         ids=[str(b.relative_to(root)) if b != root else b.name for b in bags])


@pytest.fixture(scope='session')
def cam_bench_analysis() -> Callable[[str | Path], dict[str, Any]]:
    """bag path -> the ``cam-bench analyze`` report (dict), computed once per bag."""
    from cam_metrology.offline.analyze import analyze_report

    cache: dict[Path, dict[str, Any]] = {}

    def analysis(bag: str | Path) -> dict[str, Any]:
        key = Path(bag).resolve()
        if key not in cache:
            cache[key] = analyze_report(key)
        return cache[key]

    return analysis


@pytest.fixture
def cam_bench_report(cam_bench_bag: Path,
                     cam_bench_analysis: Callable[[str | Path], dict[str, Any]],
                     ) -> dict[str, Any]:
    """The report of the current ``cam_bench_bag``."""
    return cam_bench_analysis(cam_bench_bag)

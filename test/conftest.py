"""Shared pytest fixtures.

ROS isolation: the first live ROS test of a pytest process claims a free
``ROS_DOMAIN_ID`` in 1..100 with an exclusive ``flock`` on
``$TMPDIR/cam_bench_ros_domains/<id>.lock`` (held until the process ends), and
exports it with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and a private
``ROS_LOG_DIR`` so that subprocess nodes inherit them. Parallel pytest runs (and
xdist workers) therefore never hear each other. Numeric tests never touch rclpy.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
BAGS = REPO / 'bags'
CONFIG = REPO / 'config'


@pytest.fixture(scope='session')
def ros_domain(tmp_path_factory: pytest.TempPathFactory) -> int:
    """Claim an isolated ROS domain for this pytest process; returns its id."""
    from cam_metrology.host.isolation import claim_domain

    domain = claim_domain()
    os.environ['ROS_DOMAIN_ID'] = str(domain)
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.setdefault('ROS_LOG_DIR', str(tmp_path_factory.mktemp('ros_log')))
    return domain


@pytest.fixture(scope='session')
def bags_dir() -> Path:
    """The committed fixture bags (see bags/README.md)."""
    return BAGS


@pytest.fixture(scope='session')
def config_dir() -> Path:
    """The repository's config/ folder."""
    return CONFIG

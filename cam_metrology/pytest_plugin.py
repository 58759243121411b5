"""The pytest plugin's original import path, kept for users who name it.

``pytest -p cam_metrology.pytest_plugin`` or ``pytest_plugins = ['cam_metrology.pytest_plugin']``
keeps working; the plugin itself lives in ``cam_metrology.offline.pytest_plugin`` (the
``pytest11`` entry point ``cam_bench`` loads that module).
"""
from cam_metrology.offline.pytest_plugin import (OPTION, cam_bench_analysis,  # noqa: F401
                                                 cam_bench_report, find_bags, pytest_addoption,
                                                 pytest_configure, pytest_generate_tests)

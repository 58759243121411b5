"""The golden-report comparison under its original import path, kept for users' tests.

``from cam_metrology.golden import assert_report_matches`` keeps working; the module
itself is ``cam_metrology.report.golden``.
"""
from cam_metrology.report.golden import (VOLATILE, assert_report_matches,  # noqa: F401
                                         compare_reports, golden_of)

"""Numbers in the HTML report's cells."""
from cam_metrology.report.html_cells import number


def test_a_value_rounding_to_zero_has_no_sign() -> None:
    assert number(-0.0004, '.3f') == '0.000'
    assert number(-0.0, '.1f') == '0.0'
    assert number(-0.0006, '.3f') == '-0.001'
    assert number(-2.5e-7, '.2e') == '-2.50e-07'
    assert number(None, '.3f') == '-'
    assert number(float('-inf'), '.3f') == '-inf'
    assert number(-0.0004, '.1%') == '0.0%'

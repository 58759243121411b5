"""cam_metrology.inputs.files.read_text_file: one-line errors for the user's text files."""
from __future__ import annotations

import pytest

from cam_design.errors import InputError
from cam_metrology.inputs.files import read_text_file


def test_reads_utf8_text(tmp_path) -> None:
    p = tmp_path / 'a.yaml'
    p.write_text('x: 1\n', encoding='utf-8')
    assert read_text_file(p, 'YAML file') == 'x: 1\n'


@pytest.mark.parametrize('kind, got, expected', [
    ('missing', 'no such file', 'an existing scene file'),
    ('directory', 'a directory', 'a scene file, not a directory'),
    ('binary', 'binary data', 'a UTF-8 scene file'),
])
def test_each_failure_names_file_finding_and_expectation(tmp_path, kind, got,
                                                         expected) -> None:
    p = tmp_path / 's.yaml'
    if kind == 'directory':
        p.mkdir()
    elif kind == 'binary':
        p.write_bytes(b'\xff\xfe\x00 not text')
    with pytest.raises(InputError) as info:
        read_text_file(p, 'scene file')
    assert str(info.value) == f"{p}: got '{got}'; expected {expected}"
    with pytest.raises(InputError, match=r'^t\.csv: '):
        read_text_file(p, 'table', key='t.csv')

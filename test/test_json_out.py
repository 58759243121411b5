"""The one JSON writer of every command: plain types, null for non-finite, UTF-8 file."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cam_metrology.report.json_out import json_safe, json_text, write_json


def test_numpy_and_non_finite_values_become_plain_json() -> None:
    doc = {'a': np.float64(1.25), 'n': np.int64(7), 'ok': np.bool_(True),
           'rows': np.array([[1.0, np.nan], [np.inf, -2.5]]), 't': (1, 2), 'nan': math.nan}
    back = json.loads(json_text(doc))
    assert back == {'a': 1.25, 'n': 7, 'ok': True, 'rows': [[1.0, None], [None, -2.5]],
                    't': [1, 2], 'nan': None}
    assert type(json_safe(np.int64(3))) is int


def test_text_has_no_nan_token_and_keys_sort_on_request() -> None:
    text = json_text({'b': float('nan'), 'a': 1}, sort_keys=True)
    assert 'NaN' not in text and text.endswith('\n')
    assert text.index('"a"') < text.index('"b"')


def test_file_is_utf8_and_written_whole(tmp_path: Path) -> None:
    target = tmp_path / 'out.json'
    write_json(target, {'unit': 'µm', 'x': 0.1}, '--json')
    assert json.loads(target.read_bytes().decode('utf-8')) == {'unit': 'µm', 'x': 0.1}
    assert [p.name for p in tmp_path.iterdir()] == ['out.json']


def test_a_folder_as_target_names_the_option(tmp_path: Path) -> None:
    from cam_design.errors import InputError

    with pytest.raises(InputError) as exc:
        write_json(tmp_path, {}, '--json')
    assert exc.value.key == '--json'

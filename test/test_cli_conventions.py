"""One CLI convention: `--lobe` names a lobe in every command; old spellings stay hidden
aliases (they parse, `--help` does not show them)."""
from __future__ import annotations

import pytest

from cam_metrology.cli import build_parser


def _sub(name: str):   # noqa: ANN202 - argparse's private parser type
    sub = next(a for a in build_parser()._actions if a.dest == 'command')
    return sub.choices[name]


@pytest.mark.parametrize('command', ['reconstruct', 'dynamics'])
def test_lobe_and_its_old_spelling_select_the_same_lobe(command: str) -> None:
    parser = _sub(command)
    assert parser.parse_args(['x', '--lobe', 'lobe_2']).feature == 'lobe_2'
    assert parser.parse_args(['x', '--feature', 'lobe_2']).feature == 'lobe_2'
    text = parser.format_help()
    assert '--lobe ID' in text and '--feature' not in text


def test_unknown_lobe_is_named_by_the_new_option(tmp_path, capsys) -> None:
    from pathlib import Path

    from cam_metrology.cli import main

    scene = Path(__file__).resolve().parent.parent / 'config' / 'default_scene.yaml'
    assert main(['dynamics', str(scene), '--lobe', 'nope']) == 2
    err = capsys.readouterr().err
    assert "--lobe: got 'nope'" in err or '--lobe: got nope' in err, err

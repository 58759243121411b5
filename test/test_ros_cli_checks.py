"""Argument checks of `cam-bench run | demo | replay | record` that must fail before any
ROS set-up (QA findings 5, 12, 15, 20, 21 of notes/qa.md): one line, exit 2, nothing
started. The functions that would start ROS are replaced by ones that fail the test."""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from cam_design.errors import InputError
from cam_metrology.cli import main

pytestmark = pytest.mark.ros


def _must_not_run(*_args: Any, **_kwargs: Any) -> Any:
    raise AssertionError('started ROS although the arguments are invalid')


@pytest.fixture()
def no_ros(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every entry point that would init rclpy, claim a domain or spawn a child fails."""
    import cam_metrology.host.isolation as isolation
    import cam_metrology.nodes.adapter as adapter
    import cam_metrology.nodes.demo as demo
    import cam_metrology.nodes.runtime as runtime
    monkeypatch.setattr(runtime, 'RosProcess', _must_not_run)
    monkeypatch.setattr(adapter, 'run_core_node', _must_not_run)
    monkeypatch.setattr(demo, 'start_child', _must_not_run)
    monkeypatch.setattr(isolation, 'claim_domain', _must_not_run)


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert '\n' not in err and 'Traceback' not in err, err
    return err


def test_demo_sim_unknown_or_mistyped_parameter(no_ros: None, tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(['demo', '--sim', 'bogus:=3']) == 2
    err = _error_line(capsys)
    assert "--sim: got 'bogus'" in err
    for known in ('seed', 'probe_noise', 'rate', 'runout'):
        assert known in err
    assert main(['demo', '--sim', 'seed:=x']) == 2
    assert "seed: got 'x'; expected an integer" in _error_line(capsys)
    assert main(['demo', '--sim', 'seed']) == 2
    assert 'NAME:=VALUE' in _error_line(capsys)
    assert not (tmp_path / 'demo-out').exists()


def test_demo_bad_scene_rejected_before_anything_starts(
        no_ros: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        config_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = (config_dir / 'default_scene.yaml').read_text(encoding='utf-8')
    head, sep, tail = text.partition('base_circle_radius: ')
    assert sep
    scene = tmp_path / 'negative_radius.yaml'
    scene.write_text(head + sep + '-' + tail, encoding='utf-8')
    monkeypatch.chdir(tmp_path)
    assert main(['demo', '--scene', str(scene)]) == 2
    assert 'base_circle_radius: got -' in _error_line(capsys)
    assert not (tmp_path / 'demo-out').exists()     # no empty bag left behind


def test_run_params_file_malformed_or_mistyped(no_ros: None, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / 'bad.yaml'
    bad.write_text('metrology:\n  ros__parameters:\n    fit_runout: [\n', encoding='utf-8')
    assert main(['run', 'metrology', '--params', str(bad)]) == 2
    assert 'expected valid YAML (line 4)' in _error_line(capsys)

    typed = tmp_path / 'typed.yaml'
    typed.write_text('metrology:\n  ros__parameters:\n    fit_runout: maybe\n',
                     encoding='utf-8')
    assert main(['run', 'metrology', '--params', str(typed)]) == 2
    assert _error_line(capsys).endswith(
        "metrology.fit_runout: got 'maybe'; expected true or false")

    typed.write_text('/**:\n  ros__parameters:\n    sp_pairs: 1.5\n', encoding='utf-8')
    assert main(['run', 'metrology', '--params', str(typed)]) == 2
    assert 'metrology.sp_pairs: got 1.5; expected an integer' in _error_line(capsys)

    typed.write_text('metrology:\n  ros__parameters:\n    fit_runot: false\n',
                     encoding='utf-8')
    assert main(['run', 'metrology', '--params', str(typed)]) == 2
    assert 'metrology.fit_runot: got False; expected a parameter of metrology' in \
        _error_line(capsys)

    typed.write_text('metrology:\n  fit_runout: false\n', encoding='utf-8')
    assert main(['run', 'metrology', '--params', str(typed)]) == 2
    assert 'ros__parameters' in _error_line(capsys)

    assert main(['run', 'bench-sim', '--ros-args', '-p', 'samples_per_rev:=lots']) == 2
    assert "-p samples_per_rev: got 'lots'; expected an integer" in _error_line(capsys)


def test_default_parameter_files_pass(config_dir: Path) -> None:
    from cam_metrology.nodes import NODES, NODE_NAMES, parameter_table, validate_parameters
    from cam_metrology.inputs.params import read_params_file

    for name in NODES:
        path = config_dir / f'{NODE_NAMES[name]}.yaml'
        validate_parameters(name, path, ['-p', 'use_sim_time:=false'])
        table = parameter_table(name)
        if table is not None:
            assert set(read_params_file(path, NODE_NAMES[name])) <= set(table)
    # what the demo passes to bench-sim: an empty wait_graph, an integer rate, 1e-6 floats
    validate_parameters('bench-sim', None, ['-p', 'wait_graph:=', '-p', 'rate:=5000',
                                            '-p', 'probe_noise:=1e-6'])


def test_parameter_type_messages() -> None:
    from cam_metrology.inputs.params import check_value, expected_type

    assert expected_type(3) == 'an integer'
    assert expected_type(True) == 'true or false'
    assert expected_type(0.5).startswith('a number')
    assert expected_type('') == 'a string'
    assert expected_type(None) is None
    assert check_value('k', 5, 0.5) == 5.0 and isinstance(check_value('k', 5, 0.5), float)
    for value, default in ((True, 0.5), (True, 3), (2.0, 3), ('1', 3), (1, True), (3, '')):
        expected = re.escape(str(expected_type(default)))
        with pytest.raises(InputError, match=f'^k: got .*; expected {expected}$'):
            check_value('k', value, default)


def test_replay_arguments(no_ros: None, bags_dir: Path,
                          capsys: pytest.CaptureFixture[str]) -> None:
    bag = str(bags_dir / 'default_clean')
    assert main(['replay', bag, '--topics', '/bench/scene', '/nope', '--rate', '0']) == 2
    err = _error_line(capsys)
    assert "--topics: got '/nope'; expected a topic of the bag: " in err
    assert '/bench/joint_states' in err and '/bench/scene' in err
    assert main(['replay', bag, '--expect', 'metrology:bench/joint_states']) == 2
    assert _error_line(capsys).endswith("--expect: got 'metrology:bench/joint_states'; "
                                        "expected a node name, NODE:/topic, or 'none'")
    for option, value in (('--match-timeout', '-1'), ('--match-timeout', 'nan'),
                          ('--wait-subscribers', '-2')):
        with pytest.raises(SystemExit) as exc:
            main(['replay', bag, option, value])
        assert exc.value.code == 2
        assert f"argument {option}: got '{value}'" in capsys.readouterr().err


def test_record_topic_names(no_ros: None, tmp_path: Path,
                            capsys: pytest.CaptureFixture[str]) -> None:
    from cam_metrology.nodes.recorder import parse_topic_specs

    out = tmp_path / 'rec'
    assert main(['record', str(out), '--topics', '/ok', 'bad_topic_no_slash']) == 2
    assert "--topics: got 'bad_topic_no_slash'; expected /topic or /topic:pkg/msg/Type" \
        in _error_line(capsys)
    assert not out.exists()
    for bad in ('/a//b', '/a/', '/1a', '/a-b', '/a:String', '/a:std_msgs/msg/'):
        with pytest.raises(InputError, match='--topics'):
            parse_topic_specs([bad], '--topics')
    assert parse_topic_specs('/a/b_2:std_msgs/String, /c') == {
        '/a/b_2': 'std_msgs/String', '/c': None}

"""The launch file for full ROS 2 installs, checked as far as this machine allows.

No ``launch`` / ``launch_ros`` wheels exist on PyPI, so the file is executed against
small stand-ins that record what it builds. The test then checks what a real
``ros2 launch`` would need: every executable is a console script of setup.py, every
node name is the one its parameter file is keyed by, every parameter it overrides exists
in that file, and every launch argument it reads is declared.
"""
from __future__ import annotations

import ast
import importlib.util
import sys
import types
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parent.parent
LAUNCH = REPO / 'launch' / 'cam_bench.launch.py'


class _Recorder:
    def __init__(self, *args, **kwargs) -> None:
        self.args, self.kwargs = args, kwargs


def _stubs() -> dict[str, types.ModuleType]:
    mods = {name: types.ModuleType(name) for name in (
        'launch', 'launch.actions', 'launch.conditions', 'launch.substitutions',
        'launch_ros', 'launch_ros.actions', 'ament_index_python',
        'ament_index_python.packages')}
    mods['launch'].LaunchDescription = _Recorder
    mods['launch.actions'].DeclareLaunchArgument = type('Declare', (_Recorder,), {})
    mods['launch.conditions'].IfCondition = type('IfCondition', (_Recorder,), {})
    mods['launch.substitutions'].LaunchConfiguration = type('Config', (_Recorder,), {})
    mods['launch_ros.actions'].Node = type('Node', (_Recorder,), {})
    mods['ament_index_python.packages'].get_package_share_directory = lambda pkg: str(REPO)
    return mods


@pytest.fixture
def description(monkeypatch: pytest.MonkeyPatch) -> _Recorder:
    for name, mod in _stubs().items():
        monkeypatch.setitem(sys.modules, name, mod)
    spec = importlib.util.spec_from_file_location('cam_bench_launch', LAUNCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.generate_launch_description()


def _console_scripts() -> set[str]:
    tree = ast.parse((REPO / 'setup.py').read_text())
    scripts = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                and ' = cam_metrology.nodes.entry:' in node.value:
            scripts.add(node.value.split(' = ')[0])
    return scripts


def test_nodes_match_console_scripts_and_parameter_files(description: _Recorder) -> None:
    actions = description.args[0]
    nodes = [a for a in actions if type(a).__name__ == 'Node']
    declared = {a.args[0] for a in actions if type(a).__name__ == 'Declare'}
    scripts = _console_scripts()
    assert {n.kwargs['executable'] for n in nodes} == scripts == {
        'metrology', 'reconstruction', 'dynamics', 'bench_sim', 'recorder'}
    for node in nodes:
        files = [p for p in node.kwargs['parameters'] if isinstance(p, str)]
        overrides = [p for p in node.kwargs['parameters'] if isinstance(p, dict)]
        assert len(files) == 1 and Path(files[0]).is_file(), files
        doc = yaml.safe_load(Path(files[0]).read_text())
        assert list(doc) == [node.kwargs['name']]          # keyed by the node name
        known = doc[node.kwargs['name']]['ros__parameters']
        for override in overrides:
            for key, value in override.items():
                assert key in known, (node.kwargs['name'], key)
                assert value.args[0] in declared
        condition = node.kwargs.get('condition')
        if condition is not None:
            assert condition.args[0].args[0] in declared


def test_launch_file_is_installed_by_setup_py() -> None:
    text = (REPO / 'setup.py').read_text()
    assert "glob('launch/*.launch.py')" in text and LAUNCH.is_file()
    xml = (REPO / 'package.xml').read_text()
    for dep in ('launch', 'launch_ros', 'ament_index_python'):
        assert f'<exec_depend>{dep}</exec_depend>' in xml

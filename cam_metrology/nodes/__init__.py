"""rclpy adapters: the only package (with ``cli/ros_cmds.py``) that imports rclpy.

Nodes (``cam-bench run NODE``):

* ``metrology``, ``reconstruction``, ``dynamics``: ``adapter.CoreNode`` over the
  registry's core (a missing core is reported as missing, never faked);
* ``bench-sim``: ``bench_sim.BenchSimNode`` (simulated bench from a scene file);
* ``recorder``: ``recorder.RecorderNode`` (raw CDR to a rosbag2/MCAP bag).

``run_node(name, params_file, ros_args)`` is the single entry point; each module also
has a ``main()`` for console scripts (``colcon build`` installs them to
``lib/cam_metrology``).
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

CORE_NODES = ('metrology', 'reconstruction', 'dynamics')
NODES = CORE_NODES + ('bench-sim', 'recorder')
#: ROS node name of each runnable node (the key of its parameter YAML)
NODE_NAMES = {'metrology': 'metrology', 'reconstruction': 'reconstruction',
              'dynamics': 'dynamics', 'bench-sim': 'bench_sim', 'recorder': 'recorder'}


def default_params_file(name: str) -> Path | None:
    """``config/<node_name>.yaml`` if it exists."""
    from cam_metrology.paths import config_dir
    try:
        path = config_dir() / f'{NODE_NAMES[name]}.yaml'
    except FileNotFoundError:
        return None
    return path if path.is_file() else None


def ros_arguments(params_file: str | Path | None, ros_args: Sequence[str] = ()) -> list[str]:
    """rclpy argv: ``--ros-args --params-file FILE`` plus the user's ``--ros-args ...``."""
    argv = ['cam-bench']
    extra = list(ros_args)
    if extra and extra[0] == '--ros-args':
        extra = extra[1:]
    if params_file or extra:
        argv.append('--ros-args')
        if params_file:
            argv += ['--params-file', str(params_file)]
        argv += extra
    return argv


def run_node(name: str, params_file: str | Path | None = None,
             ros_args: Sequence[str] = (), *, events_executor: bool | None = None) -> int:
    """Run node ``name`` until it is done or SIGINT/SIGTERM; returns the exit code.

    ``params_file``: ROS parameter YAML (default ``config/<node>.yaml`` if present).
    """
    if name not in NODES:
        raise ValueError(f'unknown node {name!r}; expected one of {", ".join(NODES)}')
    if params_file is None:
        params_file = default_params_file(name)
    argv = ros_arguments(params_file, ros_args)
    if name in CORE_NODES:
        from cam_metrology.nodes.adapter import run_core_node
        return run_core_node(name, argv, events_executor=bool(events_executor))
    if name == 'bench-sim':
        from cam_metrology.nodes.bench_sim import run_bench_sim
        return run_bench_sim(argv)
    from cam_metrology.nodes.recorder import events_flag_from_params, run_recorder
    if events_executor is None:
        events_executor = events_flag_from_params(str(params_file) if params_file else None)
    return run_recorder(argv, events_executor=events_executor)

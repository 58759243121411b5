"""rclpy adapters: the only package (with the ROS commands of ``cli/``) that imports rclpy.

Nodes (``cam-bench run NODE``):

* ``metrology``, ``reconstruction``, ``dynamics``, ``rig``: ``adapter.CoreNode`` over
  the registry's core (a missing core is reported as missing, never faked);
* ``bench-sim``: ``bench_sim.BenchSimNode`` (simulated bench from a scene file);
* ``recorder``: ``recorder.RecorderNode`` (raw CDR to a rosbag2/MCAP bag).

``run_node(name, params_file, ros_args)`` is the single entry point; each module also
has a ``main()`` for console scripts (``colcon build`` installs them to
``lib/cam_metrology``).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

CORE_NODES = ('metrology', 'reconstruction', 'dynamics', 'rig')
NODES = CORE_NODES + ('bench-sim', 'recorder')
#: ROS node name of each runnable node (the key of its parameter YAML)
NODE_NAMES = {'metrology': 'metrology', 'reconstruction': 'reconstruction',
              'dynamics': 'dynamics', 'bench-sim': 'bench_sim', 'recorder': 'recorder',
              'rig': 'rig'}


def default_params_file(name: str) -> Path | None:
    """``config/<node_name>.yaml`` if it exists."""
    from cam_metrology.host.paths import config_dir
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


def parameter_table(name: str) -> dict[str, Any] | None:
    """``{parameter: (default, description)}`` of node ``name`` (None for an unknown name)."""
    if name in CORE_NODES:
        from cam_metrology.offline.registry import load_core_class
        return dict(getattr(load_core_class(name), 'PARAMETERS', {}))
    if name == 'bench-sim':
        from cam_metrology.nodes import bench_sim
        from cam_metrology.rig.simulate import RIG_SIM_PARAMETERS
        return {**bench_sim.PARAMETERS, **bench_sim.sim_param_table(), **RIG_SIM_PARAMETERS}
    from cam_metrology.nodes import recorder
    return dict(recorder.PARAMETERS)


def cli_assignments(ros_args: Sequence[str]) -> list[str]:
    """The ``NAME:=VALUE`` items of ``-p``/``--param`` in ROS arguments."""
    items = list(ros_args)
    return [items[i + 1] for i, arg in enumerate(items[:-1]) if arg in ('-p', '--param')]


def validate_parameters(name: str, params_file: str | Path | None,
                        ros_args: Sequence[str] = ()) -> None:
    """Check the parameter file and the ``-p`` items of node ``name`` before rclpy reads
    them: InputError (one line) instead of rclpy's RCLError or
    InvalidParameterTypeException tracebacks."""
    from cam_metrology.inputs.params import check_params, parse_assignments, read_params_file
    table = parameter_table(name)
    if table is None:
        return
    node_name = NODE_NAMES[name]
    if params_file is not None:
        check_params(node_name, read_params_file(params_file, node_name), table)
    from cam_metrology.inputs.params import BUILTIN_PARAMETERS
    items = [item for item in cli_assignments(ros_args)
             if item.partition(':=')[0] not in BUILTIN_PARAMETERS]
    parse_assignments(items, node_name, table, '-p')


def run_node(name: str, params_file: str | Path | None = None,
             ros_args: Sequence[str] = (), *, events_executor: bool | None = None) -> int:
    """Run node ``name`` until it is done or SIGINT/SIGTERM; returns the exit code.

    ``params_file``: ROS parameter YAML (default ``config/<node>.yaml`` if present).
    """
    if name not in NODES:
        raise ValueError(f'unknown node {name!r}; expected one of {", ".join(NODES)}')
    if params_file is None:
        params_file = default_params_file(name)
    validate_parameters(name, params_file, ros_args)
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

"""ROS 2 launch file for a full ROS 2 Jazzy install (colcon build of this package).

Starts the same nodes with the same parameter files as ``cam-bench demo``:

    ros2 launch cam_metrology cam_bench.launch.py                 # simulated bench
    ros2 launch cam_metrology cam_bench.launch.py sim:=false      # a real bench publishes
    ros2 launch cam_metrology cam_bench.launch.py bag:=/data/run1 scene_file:=/data/s.yaml

Arguments: ``sim`` (start the bench simulator, default true), ``record`` (start the
recorder, default true), ``bag`` (the recorder's output directory; '' = out/rec_<time>),
``scene_file`` (the simulator's scene; '' = the packaged default scene). Node parameters
come from ``share/cam_metrology/config/<node>.yaml``, as for ``cam-bench run NODE``.
Isolation is the user's: set ``ROS_DOMAIN_ID`` (and ``ROS_AUTOMATIC_DISCOVERY_RANGE``)
before launching; ``cam-bench demo`` claims a free domain by itself.
"""
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PACKAGE = 'cam_metrology'
#: (executable = node name, parameter file) of every node the demo starts
NODES = (('metrology', 'metrology.yaml'), ('reconstruction', 'reconstruction.yaml'),
         ('dynamics', 'dynamics.yaml'))


def generate_launch_description() -> LaunchDescription:
    """The launch description: arguments, then the nodes."""
    config = os.path.join(get_package_share_directory(PACKAGE), 'config')
    args = [DeclareLaunchArgument('sim', default_value='true',
                                  description='start the bench simulator'),
            DeclareLaunchArgument('record', default_value='true',
                                  description='record every topic to a bag'),
            DeclareLaunchArgument('bag', default_value='',
                                  description="recorder output directory ('' = automatic)"),
            DeclareLaunchArgument('scene_file', default_value='',
                                  description="simulator scene ('' = packaged default)")]
    nodes = [Node(package=PACKAGE, executable=name, name=name, output='screen',
                  parameters=[os.path.join(config, params)]) for name, params in NODES]
    nodes.append(Node(package=PACKAGE, executable='recorder', name='recorder', output='screen',
                      parameters=[os.path.join(config, 'recorder.yaml'),
                                  {'output': LaunchConfiguration('bag')}],
                      condition=IfCondition(LaunchConfiguration('record'))))
    nodes.append(Node(package=PACKAGE, executable='bench_sim', name='bench_sim',
                      output='screen',
                      parameters=[os.path.join(config, 'bench_sim.yaml'),
                                  {'scene_file': LaunchConfiguration('scene_file')}],
                      condition=IfCondition(LaunchConfiguration('sim'))))
    return LaunchDescription(args + nodes)

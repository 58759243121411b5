"""ament_python packaging of cam-bench (ROS package name: cam_metrology)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'cam_metrology'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'benchmarks', 'benchmarks.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/launch', glob('launch/*.launch.py')),
        # Foxglove and PlotJuggler layouts of the plot topics (docs/ros.md)
        ('share/' + package_name + '/layouts', glob('layouts/*')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='cam-bench maintainers',
    maintainer_email='maintainers@cam-bench.invalid',
    description='Camshaft metrology, profile reconstruction and valve-train dynamics on ROS 2.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'cam-bench = cam_metrology.cli:main',
            # one per node, for `ros2 run cam_metrology <node>` after a colcon build
            'metrology = cam_metrology.nodes.entry:metrology',
            'reconstruction = cam_metrology.nodes.entry:reconstruction',
            'dynamics = cam_metrology.nodes.entry:dynamics',
            'bench_sim = cam_metrology.nodes.entry:bench_sim',
            'recorder = cam_metrology.nodes.entry:recorder',
        ],
        # pytest over recorded bags: fixtures cam_bench_analysis / cam_bench_report and
        # the option --cam-bench-bags DIR (cam_metrology/offline/pytest_plugin.py)
        'pytest11': ['cam_bench = cam_metrology.offline.pytest_plugin'],
    },
)

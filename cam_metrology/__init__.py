"""cam-bench measurement side: scene, features, metrology, reconstruction, ROS adapters."""

__version__ = '0.1.0'   # equal to setup.py and package.xml (test_provenance)

"""cam-bench measurement side: scene, features, metrology, reconstruction, ROS adapters."""

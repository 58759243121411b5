"""The machine a run happens on: config paths, the C heap, ROS domain isolation (no rclpy)."""

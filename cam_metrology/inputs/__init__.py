"""Reading the user's inputs: text files, bounded YAML, ROS parameter files (no rclpy)."""

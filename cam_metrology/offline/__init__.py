"""The analysis of recorded bags without a ROS graph: replay, registry, report, batch, plugin."""

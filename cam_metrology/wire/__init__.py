"""The wire contract of cam-bench, with no rclpy: the one place it lives.

* ``topics``: topic names, ROS types and QoS as plain data (``QosSpec``), the
  rosbag2 QoS text of each topic;
* ``cdr``: the CDR fast path (String, JointState, Float64MultiArray packed with
  struct/numpy) and the rosbags typestore for the rest;
* ``layouts``: the message layouts (table, statuses, named values), one encoder and
  one decoder each;
* ``plots``: the plot views (curves, per-part values, statuses on /diagnostics)
  derived from every node output.

Users: the live nodes (``nodes/`` converts a ``QosSpec`` to an rclpy profile and
publishes these bytes), the recorder, ``simulate``, the offline replay and the bag
writer. docs/contract.md is the same contract in words.
"""

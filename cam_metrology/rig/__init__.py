"""The valve-train test rig: measured valve motion against the dynamics (no rclpy).

A motored rig turns the camshaft at steady speeds; an encoder gives the cam angle and a
laser (or vibrometer) the valve motion, both on a time clock. This package resamples the
runs to cam angle and averages their cycles (``cycles``), finds the measured events
(``events``), compares them with the dynamics at the measured speed (``model``,
``analysis``) and calibrates the valve-train parameters by weighted least squares
through the same solver (``calibrate``); ``simulate`` makes synthetic rig runs.
Methods: docs/methods.md "Valve-train rig"; contract: docs/contract.md.
"""

"""Profile reconstruction from measured lift tables (docs/reconstruction.md).

* ``samples``  -- input tables (CSV, gauge nominal-profile files, /metrology/lift
  messages), cleaning (NaN, wrapped and repeated angles) and unit handling;
* ``spline``   -- the rebound outlier/fairing method (回弹法) finished with a quintic
  smoothing spline whose smoothing level is chosen automatically;
* ``harmonic`` -- N-harmonic approximation: full-revolution rFFT truncation and the
  working-section cosine(/sine) basis, N chosen automatically;
* ``profile``  -- the common result type, errors against the design lift, follower
  conversion and per-second derivatives;
* ``core``     -- ``ReconstructionCore``, the node core (no rclpy).

All quantities are SI: alpha [rad] from the lobe centreline, lift [m] above the base
circle, derivatives per rad (m/rad, m/rad^2, m/rad^3).
"""

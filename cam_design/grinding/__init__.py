"""Cam grinding: wheel-centre path, master cam, machining errors, correction (docs/grinding.md)."""

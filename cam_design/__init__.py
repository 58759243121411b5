"""Cam design library: lift laws, follower geometry, design checks, rocker synthesis."""

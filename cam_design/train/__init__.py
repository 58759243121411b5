"""A valve train as one object: the spec built once from the scene and its run at one
speed or over a speed sweep (``run``)."""

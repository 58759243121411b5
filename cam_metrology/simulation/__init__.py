"""The simulated measuring bench (pure numpy) and the bags it writes."""

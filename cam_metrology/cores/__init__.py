"""The contract between node cores and their transports: the core protocol and its outputs."""

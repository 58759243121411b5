"""The whole camshaft in the dynamics: a torsional shaft carrying every lobe's valve
train, its drive, and the friction of the cam-follower contacts and the journals
(docs/camshaft.md)."""

"""What goes out to people: plots, HTML report, golden comparison, provenance, nominal files."""

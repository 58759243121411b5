"""The scene: its typed model and the validating parser."""

"""The default scene as a YAML mapping for tests that edit it (no dynamics block)."""
from __future__ import annotations

import yaml


def default_doc(lobes: int | None = None) -> dict:
    """``config/default_scene.yaml`` without its valve_train, keeping the first ``lobes``
    lobes (all when None)."""
    with open('config/default_scene.yaml', encoding='utf-8') as f:
        doc = yaml.safe_load(f)
    doc.pop('valve_train')
    if lobes is not None:
        doc['lobes'] = doc['lobes'][:lobes]
    return doc

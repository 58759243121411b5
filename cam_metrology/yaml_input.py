"""YAML from outside (scene files, /bench/scene messages, parameter files, bag metadata),
loaded with bounds on its size and on what its aliases expand to.

YAML anchors and aliases let a 1 kB document stand for billions of nodes ("billion
laughs"); PyYAML shares the aliased objects, but anything that walks the document
(validation, printing, serialising) then walks every expansion. The document is first
composed (node graph, aliases shared, nothing expanded), its expanded size counted with
a memo per node, and refused above ``MAX_NODES``; only then is it constructed.
"""
from __future__ import annotations

from typing import Any

from cam_design.errors import InputError

#: largest YAML text accepted [characters]
MAX_CHARS = 5_000_000
#: largest document after alias expansion [nodes]; a scene of 3600-point tables has ~10^4
MAX_NODES = 2_000_000


def expanded_nodes(node: Any, limit: int) -> int:
    """Nodes of a composed document with every alias expanded, counted up to ``limit``
    (returns a value > ``limit`` as soon as it is exceeded). Iterative, memoised per
    node, so it is linear in the composed graph whatever the nesting and aliasing."""
    import yaml

    size: dict[int, int] = {}
    stack: list[tuple[Any, bool]] = [(node, False)]
    while stack:
        n, done = stack.pop()
        if id(n) in size:
            continue
        if isinstance(n, yaml.MappingNode):
            kids = [x for pair in n.value for x in pair]
        elif isinstance(n, yaml.SequenceNode):
            kids = list(n.value)
        else:
            size[id(n)] = 1
            continue
        if done:
            total = 1 + sum(size[id(k)] for k in kids)
            size[id(n)] = min(total, limit + 1)
        else:
            stack.append((n, True))
            stack.extend((k, False) for k in kids if id(k) not in size)
    return size.get(id(node), 0)


def load_yaml(text: str, key: str, loader: Any = None, *, max_chars: int = MAX_CHARS,
              max_nodes: int = MAX_NODES) -> Any:
    """The document of ``text`` (one), refused with InputError(``key``) when it is larger
    than ``max_chars`` or expands to more than ``max_nodes`` nodes. YAML syntax errors
    are raised as ``yaml.YAMLError`` for the caller to word."""
    import yaml

    loader = loader or yaml.SafeLoader
    if len(text) > max_chars:
        raise InputError(key, f'{len(text)} characters',
                         f'a YAML document of at most {max_chars} characters')
    node = yaml.compose(text, Loader=loader)   # noqa: S506 -- composes, builds no object
    if node is None:
        return None
    n = expanded_nodes(node, max_nodes)
    if n > max_nodes:
        raise InputError(key, f'more than {max_nodes} nodes once its aliases are expanded',
                         'a YAML document without alias bombs (anchors * and & that '
                         'repeat a block are fine, but not millions of times)')
    return yaml.load(text, Loader=loader)   # noqa: S506 -- SafeLoader or a subclass

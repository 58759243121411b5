"""YAML from outside (scene files, /bench/scene messages, parameter files, bag metadata),
loaded with bounds on its size and on what its aliases expand to.

YAML anchors and aliases let a 1 kB document stand for billions of nodes ("billion
laughs"); PyYAML shares the aliased objects, but anything that walks the document
(validation, printing, serialising) then walks every expansion. The document is first
composed (node graph, aliases shared, nothing expanded), its expanded size counted with
a memo per node, and refused above ``MAX_NODES``; only then is it constructed.

A key given twice in one mapping is refused too: YAML loaders silently keep the last
value, so a scene with two ``mass:`` lines would run with whichever came second.
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


def syntax_error_text(exc: Any, text: str) -> str:
    """A YAML syntax error in words: the problem, line and column, and for a line indented
    with a tab (which YAML forbids) the hint to indent with spaces."""
    mark = getattr(exc, 'problem_mark', None)
    problem = getattr(exc, 'problem', None) or str(exc).splitlines()[0]
    if mark is None:
        return problem
    out = f'{problem} at line {mark.line + 1}, column {mark.column + 1}'
    lines = text.splitlines()
    line = lines[mark.line] if mark.line < len(lines) else ''
    if '\t' in line[:len(line) - len(line.lstrip())]:
        out += '; that line is indented with a tab: YAML needs spaces'
    return out


def reject_duplicate_keys(node: Any, key: str) -> None:
    """InputError naming the dotted path of the first key given twice in one mapping of
    the composed document ``node`` (``key`` prefixes the message: the file or option),
    with both lines. Merge keys (``<<``) are not duplicates. Iterative; each node once."""
    import yaml

    seen: set[int] = set()
    stack: list[tuple[Any, str]] = [(node, '')]
    while stack:
        n, path = stack.pop()
        if id(n) in seen:
            continue
        seen.add(id(n))
        if isinstance(n, yaml.SequenceNode):
            stack.extend((k, f'{path}[{i}]') for i, k in enumerate(n.value))
        elif isinstance(n, yaml.MappingNode):
            first: dict[str, int] = {}
            for k, v in n.value:
                if isinstance(k, yaml.ScalarNode) and k.tag != 'tag:yaml.org,2002:merge':
                    name = k.value
                    where = f'{path}.{name}' if path else str(name)
                    if name in first:
                        raise InputError(f'{key}: {where}', name,
                                         f'unique keys in a mapping (given at lines '
                                         f'{first[name]} and {k.start_mark.line + 1}; YAML '
                                         'would silently keep the last)')
                    first[name] = k.start_mark.line + 1
                    stack.append((v, where))
                else:
                    stack.append((v, path))


def load_yaml(text: str, key: str, loader: Any = None, *, max_chars: int = MAX_CHARS,
              max_nodes: int = MAX_NODES) -> Any:
    """The document of ``text`` (one), refused with InputError(``key``) when it is larger
    than ``max_chars``, expands to more than ``max_nodes`` nodes or gives a key twice in
    one mapping (``reject_duplicate_keys``). YAML syntax errors
    are raised as ``yaml.YAMLError`` for the caller to word."""
    import yaml

    loader = loader or getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
    if len(text) > max_chars:
        raise InputError(key, f'{len(text)} characters',
                         f'a YAML document of at most {max_chars} characters')
    # parsed once (libyaml where installed): the composed node is checked, then built
    reader = loader(text)
    try:
        node = reader.get_single_node()
        if node is None:
            return None
        check_node(node, key, max_nodes)
        return reader.construct_document(node)
    finally:
        reader.dispose()


def check_node(node: Any, key: str, max_nodes: int = MAX_NODES) -> None:
    """InputError(``key``) when the composed document ``node`` expands to more than
    ``max_nodes`` nodes or gives a key twice in one mapping."""
    n = expanded_nodes(node, max_nodes)
    if n > max_nodes:
        raise InputError(key, f'more than {max_nodes} nodes once its aliases are expanded',
                         'a YAML document without alias bombs (anchors * and & that '
                         'repeat a block are fine, but not millions of times)')
    reject_duplicate_keys(node, key)

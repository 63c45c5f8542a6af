"""Every YAML the project reads goes through :func:`load` (text) or :func:`load_file` (a file): safe
tags only (PyYAML's ``SafeLoader``) and bounded, so that no input can exhaust memory or the stack.

* size: at most :data:`MAX_BYTES` of text (a file's size is checked before it is read);
* depth: at most :data:`MAX_DEPTH` nested mappings and lists (deeper input used to end in a
  ``RecursionError``);
* expansion: at most :data:`MAX_NODES` values once every alias is expanded (a few hundred bytes of
  nested aliases, the "billion laughs", expand to billions of values when walked or printed); an
  alias to a mapping or list that contains it is refused;
* keys: a key given twice in one mapping is refused (PyYAML keeps the last silently); merge keys
  (``<<: *defaults``) still override as YAML defines.

A refusal is a :class:`YAMLLimitError`, a ``yaml.YAMLError``: the readers that name their file on
a YAML error name it on these too.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from yaml.nodes import MappingNode, ScalarNode, SequenceNode

MAX_BYTES = 16 * 1024 * 1024
MAX_DEPTH = 100
MAX_NODES = 1_000_000


class YAMLLimitError(yaml.YAMLError):
    """YAML refused by a bound (size, depth, expansion) or for a repeated key."""


class BoundedLoader(yaml.SafeLoader):
    """``SafeLoader`` with the module's bounds on depth, expansion and repeated keys."""

    def __init__(self, stream: Any):
        super().__init__(stream)
        self._depth = 0
        self._sizes: dict[int, int] = {}  # id(node) -> values once expanded (the nodes stay alive in the tree)

    def compose_node(self, parent: Any, index: Any) -> Any:
        alias = self.check_event(yaml.AliasEvent)
        self._depth += 1
        if self._depth > MAX_DEPTH:
            mark = self.peek_event().start_mark
            raise YAMLLimitError(f"nested deeper than {MAX_DEPTH} levels (line {mark.line + 1})")
        try:
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        size = self._sizes.get(id(node))
        if size is None:
            if alias:  # the anchored node is still being composed: it contains itself
                raise YAMLLimitError(
                    f"an alias refers to a mapping or list that contains it (line {node.start_mark.line + 1})"
                )
            size = 1 + sum(self._sizes.get(id(child), 1) for child in _children(node))
            if size > MAX_NODES:
                raise YAMLLimitError(
                    f"expands to more than {MAX_NODES} values (aliases counted each time they are used; "
                    f"line {node.start_mark.line + 1})"
                )
            self._sizes[id(node)] = size
        return node

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, MappingNode):
            seen: dict[tuple[str, str], int] = {}
            for key, _ in node.value:
                if isinstance(key, ScalarNode) and key.tag != "tag:yaml.org,2002:merge":
                    k = (key.tag, key.value)
                    if k in seen:
                        raise YAMLLimitError(
                            f"key {_cut(key.value)!r} given twice in one mapping "
                            f"(lines {seen[k] + 1} and {key.start_mark.line + 1})"
                        )
                    seen[k] = key.start_mark.line
        return super().construct_mapping(node, deep=deep)


def _children(node: Any) -> list[Any]:
    if isinstance(node, SequenceNode):
        return list(node.value)
    if isinstance(node, MappingNode):
        return [part for pair in node.value for part in pair]
    return []


def _cut(text: str, limit: int = 60) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def load(text: str | bytes) -> Any:
    """The YAML document ``text`` as Python data, within the module's bounds
    (:class:`YAMLLimitError` otherwise, a ``yaml.YAMLError``)."""
    if len(text) > MAX_BYTES:
        raise YAMLLimitError(f"{len(text)} bytes; at most {MAX_BYTES} bytes of YAML are read")
    return yaml.load(text, Loader=BoundedLoader)  # noqa: S506 - a SafeLoader subclass


def load_file(path: str | Path) -> Any:
    """The YAML file ``path`` as Python data, its size checked before it is read (``OSError`` when
    it cannot be read, :class:`YAMLLimitError` beyond the bounds)."""
    path = Path(path)
    size = path.stat().st_size
    if size > MAX_BYTES:
        raise YAMLLimitError(f"{size} bytes; at most {MAX_BYTES} bytes of YAML are read")
    return load(path.read_text())

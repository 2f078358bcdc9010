"""The project's YAML documents (a model, an object body), read and written safely and without a node tree.

A document is size-capped (:data:`MAX_DOCUMENT_CHARS`, checked on the raw text before any parsing), holds no
alias and nests at most :data:`MAX_DOCUMENT_DEPTH` collections deep; it is read by libyaml's C parser event
by event, with PyYAML's resolver and safe constructor (:func:`parse_document`), and written by libyaml's
emitter from the safe dumper's events (:func:`document_events`). A rejected document's
``ModelFormatError.reason`` is one of :data:`DOCUMENT_REASONS`. What a model document must contain is
:mod:`grasp_intent_ros.method.model`'s.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Hashable, Iterable, Iterator
from pathlib import Path
from typing import Any

import yaml
from yaml.composer import ComposerError
from yaml.constructor import ConstructorError

from ..errors import GraspIntentError, ModelFormatError

__all__ = [
    'MAX_DOCUMENT_CHARS',
    'MAX_DOCUMENT_DEPTH',
    'DOCUMENT_REASONS',
    'OVERSIZED',
    'NOT_YAML',
    'ALIAS',
    'TOO_DEEP',
    'MALFORMED_VALUE',
    'check_document_size',
    'parse_document',
    'read_document',
    'document_events',
]

MAX_DOCUMENT_CHARS = 1 << 20
"""Largest model document read (YAML text, any header lines included), in characters: about 9 times the
shipped 7-zone models (116 kB). Checked on the raw text before any parsing."""

MAX_DOCUMENT_DEPTH = 32
"""Deepest nesting of sequences and mappings in a document read (a model document nests 4 deep)."""

OVERSIZED, NOT_YAML, ALIAS, TOO_DEEP, MALFORMED_VALUE = (
    'oversized', 'not valid YAML', 'alias', 'nested too deeply', 'malformed value')
DOCUMENT_REASONS = (OVERSIZED, NOT_YAML, ALIAS, TOO_DEEP, MALFORMED_VALUE)
"""The reasons :func:`parse_document` rejects a document for (``ModelFormatError.reason``), in the project's
own words: the same reason whichever layer stops the document first (libyaml's scanner limits flow nesting
itself, at a depth that depends on its version)."""


def check_document_size(text: str) -> None:
    """Reject a model document longer than :data:`MAX_DOCUMENT_CHARS` (a length check, no parsing).

    Raises
    ------
    ModelFormatError
        If ``text`` is oversized.
    """
    if len(text) > MAX_DOCUMENT_CHARS:
        raise ModelFormatError(f'model document is {OVERSIZED}: more than {MAX_DOCUMENT_CHARS} characters '
                               f'({len(text)} read)', reason=OVERSIZED)


_SEQUENCE_TAG, _MAPPING_TAG = 'tag:yaml.org,2002:seq', 'tag:yaml.org,2002:map'
_PLAIN_DECIMAL = re.compile(r'[-+]?[0-9]+\.[0-9]*(?:[eE][-+][0-9]+)?')
"""Plain scalars of this form (digits, a point, digits, a signed exponent: the numbers of a model document as
the safe dumper writes them, most of its scalars) resolve to floats (PyYAML's float pattern, which its
resolver tries first for these first characters, with no ``_`` and no ``:``), and ``SafeConstructor`` reads
them as ``float()`` does: :func:`_construct_events` reads them so, without the resolver's and the
constructor's Python, which would otherwise take most of a document's reading time (the planner reads one
before its first answer)."""
_NO_KEY = object()  # a mapping under construction that waits for its next key


def _construct_events(loader: Any, on_key: Callable[[Any, dict[Any, Any]], object] | None = None
                      ) -> Any:  # Any: the stubs type neither libyaml's marks nor resolve()
    """The one document of ``loader``'s event stream, built event by event with its safe constructors.

    PyYAML's own loaders compose the whole document into a node tree first (a node, its attributes and
    two marks per scalar, about 4 MB for a 116 kB model document) and only then construct it: that
    transient is what a node's first reading of a model left behind as new pymalloc arenas, pinned by
    the few objects that outlived it. Here each scalar is resolved and constructed as soon as the C
    parser reports it (with PyYAML's resolver and ``SafeConstructor``, so every scalar reads as
    ``yaml.safe_load`` reads it; a plain decimal number (:data:`_PLAIN_DECIMAL`) directly as the float
    they would make of it); only the document's own lists and dicts are ever held (peak 0.6 MB
    for that document). Collections are built on an explicit stack, so nesting is bounded
    (:data:`MAX_DOCUMENT_DEPTH`) without recursion. Raises yaml.YAMLError (aliases, a tag other than a
    plain sequence, mapping or safe scalar, an unhashable key, several documents), ModelFormatError
    (nesting too deep, an alias). ``on_key(key, mapping)`` is called as each key of a top-level mapping is read,
    with the fields before it complete: it may raise to stop reading there.
    """
    loader.get_event()  # StreamStartEvent
    if loader.check_event(yaml.StreamEndEvent):
        return None
    loader.get_event()  # DocumentStartEvent
    stack: list[tuple[list[Any] | dict[Any, Any], Any]] = []  # open collections, each with its pending key
    while True:
        event = loader.get_event()
        start, end = event.start_mark, event.end_mark  # libyaml's marks, for the messages
        if isinstance(event, yaml.ScalarEvent):
            if event.tag is None and event.implicit[0] and _PLAIN_DECIMAL.fullmatch(event.value):
                value: Any = float(event.value)
            else:
                tag = event.tag if event.tag not in (None, '!') else loader.resolve(yaml.ScalarNode, event.value,
                                                                                      event.implicit)
                construct = loader.yaml_constructors.get(tag, loader.yaml_constructors[None])  # None: unknown tag
                value = construct(loader, yaml.ScalarNode(tag, event.value, start, end, style=event.style))
        elif isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            sequence = isinstance(event, yaml.SequenceStartEvent)
            tag = event.tag if event.tag not in (None, '!') else loader.resolve(
                yaml.SequenceNode if sequence else yaml.MappingNode, None, event.implicit)
            if tag != (_SEQUENCE_TAG if sequence else _MAPPING_TAG):
                raise ConstructorError(None, None, f'the tag {tag!r} is not allowed in a model document',
                                       start)
            if len(stack) >= MAX_DOCUMENT_DEPTH:
                raise _too_deep()
            stack.append(([] if sequence else {}, _NO_KEY))
            continue
        elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            value = stack.pop()[0]
        elif isinstance(event, yaml.AliasEvent):
            raise ModelFormatError(f'model document holds an {ALIAS} (*name): aliases are not allowed', reason=ALIAS)
        else:  # the parser reports nothing else inside a document
            raise ComposerError(f'unexpected {type(event).__name__} in a model document')
        if not stack:
            break
        container, key = stack[-1]
        if isinstance(container, list):
            container.append(value)
        elif key is _NO_KEY:
            if not isinstance(value, Hashable):
                raise ConstructorError('while constructing a mapping', None, 'found an unhashable key', start)
            stack[-1] = (container, value)
            if on_key is not None and len(stack) == 1:
                on_key(value, container)
        else:
            container[key] = value
            stack[-1] = (container, _NO_KEY)
    loader.get_event()  # DocumentEndEvent
    if not loader.check_event(yaml.StreamEndEvent):
        raise ComposerError('expected a single document in the stream', None, 'but found another document',
                            loader.peek_event().start_mark)
    return value


_REPRESENTER = yaml.representer.SafeRepresenter(default_flow_style=False, sort_keys=False)
_RESOLVER: Any = yaml.resolver.Resolver()  # Any: the stubs leave resolve() untyped


def document_events(data: Any) -> Iterator[yaml.Event]:
    """The events PyYAML's safe dumper serializes ``data`` to, one at a time.

    ``data``: plain dicts (with scalar keys), lists and scalars.

    ``yaml.dump`` first represents the whole document as a node tree (3 MB of Python objects for a 7-zone
    model) and then serializes it; these are the same events (block style, keys in order, each scalar
    represented by ``SafeRepresenter`` and tagged implicitly as the serializer does), without the tree.
    """
    yield yaml.StreamStartEvent()
    yield yaml.DocumentStartEvent(explicit=False)
    stack: list[Iterator[Any]] = [iter((data,))]
    while stack:
        item: Any = next(stack[-1], _NO_KEY)
        if item is _NO_KEY:  # the end of a collection (or, last, of the document)
            ended = stack.pop()
            if stack:
                yield yaml.MappingEndEvent() if isinstance(ended, _Pairs) else yaml.SequenceEndEvent()
            continue
        for value in (item if isinstance(stack[-1], _Pairs) else (item,)):
            if isinstance(value, dict):
                yield yaml.MappingStartEvent(None, _MAPPING_TAG, True, flow_style=False)
                stack.append(_Pairs(value.items()))
            elif isinstance(value, list):
                yield yaml.SequenceStartEvent(None, _SEQUENCE_TAG, True, flow_style=False)
                stack.append(iter(value))
            else:
                node: Any = _REPRESENTER.represent_data(value)  # a ScalarNode
                implicit = (node.tag == _RESOLVER.resolve(yaml.ScalarNode, node.value, (True, False)),
                            node.tag == _RESOLVER.resolve(yaml.ScalarNode, node.value, (False, True)))
                yield yaml.ScalarEvent(None, node.tag, implicit, node.value, style=node.style)
    yield yaml.DocumentEndEvent(explicit=False)
    yield yaml.StreamEndEvent()


class _Pairs(Iterator[tuple[Any, Any]]):
    """A mapping's items being written (a key and its value each)."""

    def __init__(self, items: Iterable[tuple[Any, Any]]) -> None:
        self._items = iter(items)

    def __next__(self) -> tuple[Any, Any]:
        return next(self._items)


def parse_document(text: str, *, on_key: Callable[[Any, dict[Any, Any]], object] | None = None) -> Any:
    """Parse a YAML document of this project (a model, an object body) safely.

    Size-capped (:data:`MAX_DOCUMENT_CHARS`, checked before parsing), no aliases, nesting at most
    :data:`MAX_DOCUMENT_DEPTH` collections deep; scalars read as ``yaml.safe_load`` reads them, by
    libyaml's parser (C) and PyYAML's safe constructor, without a node tree (see :func:`_construct_events`).
    ``on_key(key, mapping)`` sees each key of a top-level mapping as it is read, with the fields before it
    (e.g. to refuse a document by its declaration before its arrays are parsed); a GraspIntentError it
    raises ends the parse and propagates.

    Raises
    ------
    ModelFormatError
        For an oversized text, invalid YAML, an alias, a merge key (``<<``), nesting too deep, or a
        malformed scalar.
    """
    check_document_size(text)
    loader = yaml.CSafeLoader(text)
    try:
        return _construct_events(loader, on_key)
    except GraspIntentError:
        raise
    except yaml.YAMLError as exc:
        mark = getattr(exc, 'problem_mark', None)
        if mark is not None and _flow_depth(text[:mark.index]) > MAX_DOCUMENT_DEPTH:
            raise _too_deep() from None  # libyaml's scanner stopped the nesting before this reader did
        raise ModelFormatError(f'model document is {NOT_YAML}: {exc}', reason=NOT_YAML) from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise ModelFormatError(f'model document holds a {MALFORMED_VALUE}: {exc}', reason=MALFORMED_VALUE) from None
    finally:
        loader.dispose()


def _too_deep() -> ModelFormatError:
    return ModelFormatError(f'model document is {TOO_DEEP} (more than {MAX_DOCUMENT_DEPTH} levels)', reason=TOO_DEEP)


def _flow_depth(prefix: str) -> int:
    """Flow collections (``[``, ``{``) opened and not yet closed in ``prefix``.

    Brackets inside quoted scalars count too: this only names why a parse that already failed stopped.
    """
    return prefix.count('[') + prefix.count('{') - prefix.count(']') - prefix.count('}')


def read_document(path: str | Path) -> str:
    """A document file's text, at most one character more than :data:`MAX_DOCUMENT_CHARS` (enough to reject it).

    Raises
    ------
    OSError
        If the file cannot be read.
    """
    with Path(path).open() as file:
        return file.read(MAX_DOCUMENT_CHARS + 1)

"""Hypothesis strategies that break an input file the ways people and disks do: a key deleted,
repeated or misspelt, a value of the wrong type, NaN and infinities, huge and negative numbers,
a file cut short, random bytes. Each draws the mutated file's bytes from a valid original."""

from __future__ import annotations

import math
from collections.abc import Callable

import yaml
from hypothesis import strategies as st

#: Values that replace a node: wrong types, non-finite, huge, negative, empty, unit-suffixed.
ODD_VALUES = (
    "text",
    "",
    "1 m",
    "2e4",
    True,
    False,
    None,
    0,
    -1,
    7,
    2.5,
    -1e9,
    1e308,
    -1e308,
    10**30,
    math.nan,
    math.inf,
    -math.inf,
    2e4,
    [],
    {},
    [1, 2],
    [[0, 0], [1, 0]],
    {"a": 1},
)
MUTATIONS = ("delete", "replace", "rename", "insert", "repeat_line", "truncate", "random_bytes", "flip_bytes")


def _paths(node: object, prefix: tuple = ()) -> list[tuple]:
    """Every path (tuple of keys and indices) to a node below the root."""
    out: list[tuple] = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, child in items:
        out.append((*prefix, key))
        out.extend(_paths(child, (*prefix, key)))
    return out


def _parent(doc: object, path: tuple) -> object:
    for key in path[:-1]:
        doc = doc[key]  # type: ignore[index]
    return doc


def _edit(doc: object, draw: Callable, how: str) -> object:
    paths = _paths(doc)
    if not paths:
        return draw(st.sampled_from(ODD_VALUES))
    path = draw(st.sampled_from(paths))
    parent, key = _parent(doc, path), path[-1]
    if how == "delete":
        del parent[key]  # type: ignore[attr-defined]
    elif how == "replace":
        parent[key] = draw(st.sampled_from(ODD_VALUES))  # type: ignore[index]
    elif how == "rename" and isinstance(parent, dict):
        parent[draw(st.sampled_from(["colour", "Name", "x", "1", "cell m"]))] = parent.pop(key)
    elif how == "insert":
        target = parent[key]  # type: ignore[index]
        if isinstance(target, dict):
            new_key = draw(st.sampled_from(["extra", "name", "type", "kind"]))
            target[new_key] = draw(st.sampled_from(ODD_VALUES))
        elif isinstance(target, list):
            target.append(draw(st.sampled_from(ODD_VALUES)))
        else:
            parent[key] = [target, target]  # type: ignore[index]
    return doc


@st.composite
def mutated_text(draw: Callable, original: str, dump: Callable[[object], str] | None = None) -> bytes:
    """A mutation of a YAML (or JSON, with `dump=json.dumps`) text, as bytes."""
    how = draw(st.sampled_from(MUTATIONS))
    data = original.encode("utf-8")
    if how == "truncate":
        return data[: draw(st.integers(0, max(0, len(data) - 1)))]
    if how == "random_bytes":
        return draw(st.binary(max_size=200))
    if how == "flip_bytes":
        return _flip(draw, data)
    if how == "repeat_line":
        lines = original.splitlines(keepends=True)
        keyed = [i for i, line in enumerate(lines) if ":" in line and not line.lstrip().startswith("#")]
        i = draw(st.sampled_from(keyed or [0]))
        j = draw(st.integers(i + 1, len(lines)))
        return "".join([*lines[:j], lines[i], *lines[j:]]).encode("utf-8")
    doc = _edit(yaml.safe_load(original), draw, how)
    text = dump(doc) if dump is not None else yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
    return text.encode("utf-8")


def _flip(draw: Callable, data: bytes) -> bytes:
    if not data:
        return data
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 8))):
        out[draw(st.integers(0, len(out) - 1))] = draw(st.integers(0, 255))
    return bytes(out)


@st.composite
def mutated_bytes(draw: Callable, original: bytes) -> bytes:
    """A binary file cut short, with bytes overwritten, or replaced by random bytes."""
    how = draw(st.sampled_from(("truncate", "flip_bytes", "random_bytes", "empty")))
    if how == "truncate":
        return original[: draw(st.integers(0, len(original) - 1))]
    if how == "flip_bytes":
        return _flip(draw, original)
    if how == "random_bytes":
        return draw(st.binary(max_size=400))
    return b""


#: Tokens that replace a number of a whitespace-separated table (a DEM, an encoder log).
ODD_TOKENS = ("nan", "inf", "-inf", "1e400", "-1", "0", "x", "999999999999", "1.5", "", "ncols", "0x10")


@st.composite
def mutated_table(draw: Callable, original: str) -> bytes:
    """A whitespace-separated table with one token swapped for an odd one, or cut, repeated and
    overwritten line by line like any text."""
    if draw(st.booleans()):
        tokens = original.split(" ")
        i = draw(st.integers(0, len(tokens) - 1))
        tail = "\n" if tokens[i].endswith("\n") else ""
        tokens[i] = draw(st.sampled_from(ODD_TOKENS)) + tail
        return " ".join(tokens).encode()
    how = draw(st.sampled_from(("truncate", "random_bytes", "flip_bytes", "repeat_line", "drop_line")))
    data = original.encode("utf-8")
    if how == "truncate":
        return data[: draw(st.integers(0, max(0, len(data) - 1)))]
    if how == "random_bytes":
        return draw(st.binary(max_size=200))
    if how == "flip_bytes":
        return _flip(draw, data)
    lines = original.splitlines(keepends=True)
    i = draw(st.integers(0, len(lines) - 1))
    if how == "drop_line":
        return "".join(lines[:i] + lines[i + 1 :]).encode()
    j = draw(st.integers(0, len(lines)))
    return "".join([*lines[:j], lines[i], *lines[j:]]).encode()

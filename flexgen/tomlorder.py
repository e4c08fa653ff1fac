"""The document order of a TOML file's arrays of tables (``[[flexure]]``, ``[[link]]``, or inline).

``tomllib`` keeps each array of tables in its own list, so the order in which two arrays
interleave in the file is lost. This module reads it back with a small scanner of the TOML
grammar (strings of all four kinds, comments, arrays and inline tables spanning lines, dotted and
quoted keys); no regular expression is run over the text. It is meant for text that ``tomllib``
has already accepted: it only has to find where each top-level statement begins, and it decodes
a quoted header key with ``tomllib`` itself (so ``[["fle\\u0078ure"]]`` is ``flexure``). One pass,
linear in the length of the text.
"""

from __future__ import annotations

import tomllib

_BARE = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-")
_SPACE = " \t\r"


class _Scan:
    def __init__(self, text: str):
        self.text = text
        self.n = len(text)

    def string_end(self, i: int) -> int:
        """The index just past the string starting at ``i`` (a quote character)."""
        t, q = self.text, self.text[i]
        if t.startswith(q * 3, i):  # multi-line: ends at the first unescaped triple quote
            j = i + 3
            while True:
                k = t.find(q * 3, j)
                if k < 0:
                    return self.n
                if q == '"' and _escaped(t, k):
                    j = k + 1
                    continue
                k += 3
                extra = 0  # up to two more quotes belong to the content (""""a"""" is legal)
                while extra < 2 and k < self.n and t[k] == q:
                    k += 1
                    extra += 1
                return k
        j = i + 1
        while True:
            k = t.find(q, j)
            if k < 0:
                return self.n
            if q == '"' and _escaped(t, k):
                j = k + 1
                continue
            return k + 1

    def line_end(self, i: int) -> int:
        k = self.text.find("\n", i)
        return self.n if k < 0 else k

    def key(self, i: int) -> tuple[tuple[str, ...] | None, int]:
        """A dotted key from ``i`` (whitespace skipped): (its parts, the index after it)."""
        t = self.text
        parts: list[str] = []
        while True:
            while i < self.n and t[i] in " \t":
                i += 1
            if i < self.n and t[i] in "\"'":
                end = self.string_end(i)
                try:
                    parts.append(tomllib.loads(f"k = {t[i:end]}")["k"])
                except (tomllib.TOMLDecodeError, KeyError):
                    return None, end
                i = end
            else:
                start = i
                while i < self.n and t[i] in _BARE:
                    i += 1
                if i == start:
                    return None, i
                parts.append(t[start:i])
            while i < self.n and t[i] in " \t":
                i += 1
            if i < self.n and t[i] == ".":
                i += 1
                continue
            return tuple(parts), i


def _escaped(text: str, k: int) -> bool:
    """True if the character at ``k`` is preceded by an odd number of backslashes."""
    count = 0
    k -= 1
    while k >= 0 and text[k] == "\\":
        count += 1
        k -= 1
    return count % 2 == 1


def array_order(text: str) -> list[tuple[tuple[str, ...], bool]]:
    """Where a valid TOML document adds to its arrays of tables, in document order: (the key,
    False) for every ``[[key]]`` header, and (the key, True) for every key assigned in the root
    table before the first header (``flexure = [{...}, {...}]``: an inline array, whose items
    all sit at that place; the caller keeps the keys it knows to be arrays)."""
    s = _Scan(text)
    t, n = text, s.n
    headers: list[tuple[tuple[str, ...], bool]] = []
    i = 0
    depth = 0  # open [ and { inside a value
    line_start = True  # at the start of a top-level statement
    in_root = True  # before the first table header: a statement there is a root key
    while i < n:
        c = t[i]
        if c in _SPACE:
            i += 1
        elif c == "\n":
            if depth == 0:
                line_start = True
            i += 1
        elif c == "#":
            i = s.line_end(i)
        elif line_start and depth == 0 and in_root and c != "[":
            key, i = s.key(i)  # a root key (bare or quoted): its value is scanned as any other
            if key is not None:
                headers.append((key, True))
            line_start = False
        elif c in "\"'":
            line_start = False
            i = s.string_end(i)
        elif line_start and depth == 0 and c == "[":
            is_array = t.startswith("[[", i)
            key, i = s.key(i + (2 if is_array else 1))
            if is_array and key is not None:
                headers.append((key, False))
            i = s.line_end(i)  # the rest of a header line: "]]" and an optional comment
            line_start = True
            in_root = False
        else:
            line_start = False
            if c in "[{":
                depth += 1
            elif c in "]}":
                depth -= 1
            i += 1
    return headers

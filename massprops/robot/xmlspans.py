"""XML for the readers: the file parsed with each element's byte offsets, and small shared helpers.

:mod:`massprops.robot.write` replaces the bytes of single elements and must
leave every other byte as it was, so it needs to know where each element
starts and ends in the file; lxml gives line numbers only.  A small scanner
walks the tags (skipping comments, CDATA, processing instructions and the
document type) and pairs them with lxml's elements, which come in the same
document order.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .model import Decimal, RobotFormatError

__all__ = ["Span", "parse_with_spans", "element_spans", "parse_numbers", "line_of", "the_shape"]

_NAME = rb"[A-Za-z_:][-\w:.]*"
_START = re.compile(rb"<(" + _NAME + rb")((?:\s+" + _NAME + rb"\s*=\s*(?:\"[^\"]*\"|'[^']*'))*)\s*(/?)>")
_END = re.compile(rb"</(" + _NAME + rb")\s*>")
_SKIP = ((b"<!--", b"-->"), (b"<![CDATA[", b"]]>"), (b"<?", b"?>"))


@dataclass(frozen=True)
class Span:
    """Where one element sits: ``start`` at its ``<``, ``content`` just after its start tag, ``end`` after its close."""

    tag: str
    start: int
    content: int
    end: int

    @property
    def self_closing(self):
        return self.content == self.end


def _doctype_end(data, at):
    """End of ``<!DOCTYPE ...>``, an internal subset ``[...]`` included."""
    depth, i = 0, at + 2
    while i < len(data):
        c = data[i:i + 1]
        if c == b"[":
            depth += 1
        elif c == b"]":
            depth -= 1
        elif c == b">" and depth <= 0:
            return i + 1
        i += 1
    return len(data)


def element_spans(data):
    """Every element's :class:`Span`, in document order (the order lxml's ``iter()`` gives).

    Raises
    ------
    ValueError
        Tags that do not nest or do not parse.
    """
    spans, stack, i = [], [], 0
    while True:
        i = data.find(b"<", i)
        if i < 0:
            break
        for opener, closer in _SKIP:
            if data.startswith(opener, i):
                stop = data.find(closer, i + len(opener))
                i = len(data) if stop < 0 else stop + len(closer)
                break
        else:
            if data.startswith(b"<!", i):
                i = _doctype_end(data, i)
                continue
            end = _END.match(data, i)
            if end:
                if not stack or spans[stack[-1]][0] != end.group(1):
                    raise ValueError(f"unexpected </{end.group(1).decode(errors='replace')}> at byte {i}")
                k = stack.pop()
                spans[k][3] = end.end()
                i = end.end()
                continue
            start = _START.match(data, i)
            if not start:
                raise ValueError(f"cannot read the tag at byte {i}")
            closed = bool(start.group(3))
            spans.append([start.group(1), i, start.end(), start.end() if closed else None])
            if not closed:
                stack.append(len(spans) - 1)
            i = start.end()
    if stack:
        raise ValueError("unclosed elements")
    return [Span(tag.decode("utf-8", "replace"), s, c, e) for tag, s, c, e in spans]


def _local(tag):
    return tag.rpartition("}")[2] if tag.startswith("{") else tag.rpartition(":")[2]


_DECLARATION = re.compile(rb"<\?xml[^>]*\?>")
_DECLARATION_PROBLEMS = ("Unsupported version", "XML declaration allowed only at the start")


def _lenient(data, parser, path, exc):
    """Parse again without the XML declaration when only it is at fault (``version="0.0"``, written by
    some exporters and read by urdfdom and pybullet, or a declaration after a comment).  It is blanked out
    with as many spaces, so every byte offset stays the file's."""
    from lxml import etree
    match = _DECLARATION.search(data)
    if match and any(problem in str(exc) for problem in _DECLARATION_PROBLEMS):
        blanked = data[:match.start()] + b" " * (match.end() - match.start()) + data[match.end():]
        try:
            return etree.fromstring(blanked, parser=parser, base_url=str(path))
        except etree.XMLSyntaxError:
            pass
    raise RobotFormatError(f"not well-formed XML ({exc})", path=path,
                           fix="fix the XML (an editor or `xmllint FILE` shows where)") from None


def parse_with_spans(path, *, data=None):
    """Parse an XML file with lxml and pair each element with its :class:`Span`.

    Returns
    -------
    (lxml root element, dict element -> Span or None, bytes)
        The spans are None when the scanner and lxml disagree (entities that
        expand to elements, say); the file is then read but not written.
    """
    from lxml import etree

    if data is None:
        with open(path, "rb") as handle:
            data = handle.read()
    parser = etree.XMLParser(remove_comments=False, resolve_entities=False, huge_tree=True)
    try:
        root = etree.fromstring(data, parser=parser, base_url=str(path))
    except etree.XMLSyntaxError as exc:
        root = _lenient(data, parser, path, exc)
    elements = [e for e in root.getroottree().iter() if isinstance(e.tag, str)]
    try:
        spans = element_spans(data)
    except ValueError:
        spans = None
    if spans is None or len(spans) != len(elements) or any(
            _local(s.tag) != _local(e.tag) for s, e in zip(spans, elements)):
        return root, None, data
    return root, dict(zip(elements, spans)), data


def parse_numbers(text, count, *, what, path=None):
    """``count`` Decimals from whitespace-separated ``text`` (RobotFormatError otherwise)."""
    tokens = (text or "").split()
    if len(tokens) != count:
        raise RobotFormatError(f"{what}: expected {count} numbers, got {text!r}", path=path)
    return [Decimal.parse(t, what=what, path=path) for t in tokens]


def line_of(element):
    """`` (line N)`` for messages, or nothing when lxml does not know the line."""
    return f" (line {element.sourceline})" if element.sourceline else ""


def the_shape(element, where, path):
    """The one shape element inside ``element``'s ``<geometry>``."""
    holder = element.find("geometry")
    shapes = [] if holder is None else [c for c in holder if isinstance(c.tag, str)]
    if len(shapes) != 1:
        raise RobotFormatError(f"{where}: <geometry> must hold one shape, found {len(shapes)}", path=path)
    return shapes[0]

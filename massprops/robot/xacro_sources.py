"""Where each link of an expanded xacro file was written: the ``.xacro`` file, and the bytes of its ``<inertial>``.

xacro's output keeps no trace of where an element came from, so each
expanded link is looked for in the files the expansion read (the model file
and those it included), by its name:

- a ``<link name="NAME">`` written literally, once, whose ``<inertial>`` is
  literal too (no ``${...}``, no ``$(...)``, no xacro element inside): the
  writer replaces that element's bytes in that file, or inserts one after the
  link's start tag when the link has none and no macro call could make one;
- otherwise the inertial comes from a macro, and the reason names it: the
  macro whose body writes the link (its name pattern matching the expanded
  name), or the macro called inside the link for its inertial, with the file
  and line of the call or of the definition.  ``robot write --expand`` writes
  the expanded URDF instead.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field, replace

from .xmlspans import parse_with_spans

__all__ = ["XacroSources", "locate", "with_sources", "expanded"]

_XACRO = "{http://www.ros.org/wiki/xacro}"
_EXPRESSION = re.compile(r"\$\{[^}]*\}|\$\([^)]*\)")


@dataclass
class XacroSources:
    """``sources`` {file: bytes}; ``links`` {name: (file, link span, insert_at, inertial span or None, line)};
    ``unwritable`` {name: why its inertial is not literal, naming the macro}."""

    sources: dict = field(default_factory=dict)
    links: dict = field(default_factory=dict)
    unwritable: dict = field(default_factory=dict)


def _local(tag):
    return tag.rpartition("}")[2] if isinstance(tag, str) else ""


def _is_xacro(element):
    return isinstance(element.tag, str) and element.tag.startswith(_XACRO)


def _literal(element):
    """Whether ``element`` and everything in it is plain XML: no xacro element, no expression."""
    for node in element.iter():
        if not isinstance(node.tag, str):
            continue
        if _is_xacro(node):
            return False
        if any(_EXPRESSION.search(v) for v in node.attrib.values()) or _EXPRESSION.search(node.text or ""):
            return False
    return True


def _macro_of(element):
    """The ``<xacro:macro>`` element around ``element``, or None."""
    parent = element.getparent()
    while parent is not None:
        if _is_xacro(parent) and _local(parent.tag) == "macro":
            return parent
        parent = parent.getparent()
    return None


def _where(file, element):
    return f"{os.path.basename(file)} line {element.sourceline}" if element.sourceline else os.path.basename(file)


def _macros(trees):
    """``{macro name: (file, element)}`` of every ``<xacro:macro>`` in the files read."""
    out = {}
    for file, (root, _) in trees.items():
        for element in root.iter(_XACRO + "macro"):
            out.setdefault(element.get("name", ""), (file, element))
    return out


def _called(link_element, macros, file):
    """Why the inertial of a literal link is not literal: the macro call (or expression) inside it."""
    inertials = [c for c in link_element if _local(c.tag) == "inertial" and not _is_xacro(c)]
    if inertials:
        expressions = sorted({m.group(0) for node in inertials[0].iter() if isinstance(node.tag, str)
                              for v in node.attrib.values() for m in _EXPRESSION.finditer(v)})
        shown = ", ".join(expressions[:3]) + (" ..." if len(expressions) > 3 else "")
        return (f"its <inertial> ({_where(file, inertials[0])}) is written with expressions ({shown}): "
                "write the values there")
    for child in link_element.iter():
        if _is_xacro(child) and _local(child.tag) not in ("if", "unless", "property", "arg"):
            name = _local(child.tag) if _local(child.tag) != "call" else child.get("macro", "")
            defined = macros.get(name)
            at = f", defined in {_where(*defined)}" if defined else ""
            return (f"its inertial comes from the macro call <xacro:{name}> ({_where(file, child)}{at}): "
                    "give that call the arguments that produce these values")
    return None


def locate(model, main, includes):
    """:class:`XacroSources` for the links of ``model`` (expanded from ``main``, which read ``includes``)."""
    found = XacroSources()
    trees = {}
    for file in dict.fromkeys([os.path.abspath(main), *includes]):
        try:
            root, spans, data = parse_with_spans(file)
        except Exception:  # noqa: BLE001 - a file xacro read but lxml cannot: its links are not located
            continue
        trees[file] = (root, spans)
        found.sources[file] = data
    literal, patterned = {}, []
    for file, (root, spans) in trees.items():
        for element in root.iter("link"):
            name = element.get("name", "")
            if _EXPRESSION.search(name):
                pieces, last = [], 0
                for match in _EXPRESSION.finditer(name):
                    pieces += [re.escape(name[last:match.start()]), ".*"]
                    last = match.end()
                pieces.append(re.escape(name[last:]))
                patterned.append((re.compile("".join(pieces), re.S), file, element))
            else:
                literal.setdefault(name, []).append((file, element, spans))
    macros = _macros(trees)
    for link in model.links:
        places = literal.get(link.name, [])
        if len(places) == 1:
            file, element, spans = places[0]
            reason = _placed(found, link, file, element, spans, macros)
        elif len(places) > 1:
            reason = (f"the link is written {len(places)} times ("
                      f"{', '.join(_where(f, e) for f, e, _ in places)}); which one xacro kept depends on "
                      "conditions: write the values in the one meant")
        else:
            matches = [(f, e) for pattern, f, e in patterned if pattern.fullmatch(link.name)]
            if matches:
                file, element = matches[0]
                macro = _macro_of(element)
                if macro is not None:
                    params = macro.get("params", "")
                    reason = (f"the link is made by the macro '{macro.get('name')}' ({_where(file, macro)}, "
                              f"params: {params or 'none'}; the link at {_where(file, element)}): give its "
                              "inertial these values through the macro's arguments")
                else:
                    reason = f"the link's name is computed ({_where(file, element)}): write the values there"
            else:
                reason = "the link could not be found in the xacro files"
        if reason is not None:
            found.unwritable[link.name] = reason + " — or write the expanded URDF ({expand})"
    return found


def _placed(found, link, file, element, spans, macros):
    """Record where ``link``'s inertial goes in ``file``; the reason it cannot be written there, or None."""
    if spans is None:
        return f"{os.path.basename(file)} could not be located byte by byte"
    span = spans.get(element)
    inertials = [c for c in element if _local(c.tag) == "inertial" and not _is_xacro(c)]
    if len(inertials) == 1 and _literal(inertials[0]):
        inner = spans.get(inertials[0])
        found.links[link.name] = (file, (span.start, span.end), span.content, (inner.start, inner.end),
                                  inertials[0].sourceline)
        return None
    reason = _called(element, macros, file)
    if reason is not None:
        return reason
    if link.declared is None and not span.self_closing:
        found.links[link.name] = (file, (span.start, span.end), span.content, None, None)
        return None
    if span.self_closing:
        return f"the link's element is empty ({_where(file, element)}): write its inertial there by hand"
    return f"its inertial is not written in the link's element ({_where(file, element)})"


def with_sources(model, located):
    """``model`` whose links carry the spans of their ``.xacro`` source, and its ``extra`` what the writer needs."""
    links = []
    for link in model.links:
        place = located.links.get(link.name)
        if place is None:
            declared = replace(link.declared, span=None) if link.declared is not None else None
            links.append(replace(link, span=None, insert_at=None, declared=declared))
            continue
        file, span, insert_at, inertial_span, line = place
        declared = link.declared
        if declared is not None:
            declared = replace(declared, span=inertial_span, line=line or declared.line)
        links.append(replace(link, span=span, insert_at=insert_at, declared=declared))
    main = os.path.abspath(model.path)
    extra = {**model.extra, "sources": located.sources,
             "link_files": {name: place[0] for name, place in located.links.items()},
             "unwritable": dict(located.unwritable), "expanded": (model.source, model.links)}
    return replace(model, links=tuple(links), source=located.sources.get(main, b""), extra=extra, writable=None)


def expanded(model):
    """The model as the expanded URDF it was read from (``robot write --expand``): its bytes and spans."""
    if "expanded" not in model.extra:
        return model
    source, links = model.extra["expanded"]
    extra = {k: v for k, v in model.extra.items() if k not in ("sources", "link_files", "unwritable", "expanded")}
    return replace(model, links=links, source=source, extra=extra)

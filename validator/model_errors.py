"""A pydantic validation error as one line that names the field, as a user wrote it."""

from __future__ import annotations

from pydantic import ValidationError


def field_path(loc: tuple[int | str, ...], data: object) -> str:
    """``('ground_nodes', 1, 'x')`` -> ``ground_nodes[1] (GN2).x``."""
    out = ""
    node = data
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
            try:
                node = node[part] if isinstance(node, (list, dict)) else None
                if isinstance(node, dict) and "name" in node:
                    out += f" ({node['name']})"
            except (IndexError, KeyError, TypeError):
                node = None
        else:
            out += f".{part}" if out else str(part)
            node = node.get(part) if isinstance(node, dict) else None
    return out


def first_error(err: ValidationError, data: object, root: str = "file") -> str:
    """The first error pydantic found in ``data``, as ``field path: message`` (``root`` when
    it names no field)."""
    e = err.errors()[0]
    loc = tuple(p for p in e["loc"] if not (isinstance(p, str) and p.startswith("function-")))
    msg = str(e["msg"]).removeprefix("Value error, ")
    if e["type"] == "extra_forbidden":
        msg = "unknown key"
    elif e["type"] == "missing":
        msg = "missing field"
    where = field_path(loc, data) or root
    return f"{where}: {msg}"

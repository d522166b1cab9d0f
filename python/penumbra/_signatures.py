"""The keyword arguments of render() and bake(), made from the library's descriptions of the
options (penumbra.h: options(), the same descriptions the command line parses with): a
signature with every option a named, typed, keyword-only parameter, and the docstring section
that lists them with their ranges and each method's default."""

from __future__ import annotations

import inspect
import re
from typing import List, Optional, Union

from ._penumbra import _options

# The Python type of each kind of option (docs/cli.md).
_TYPES = {
    "flag": bool,
    "int": int,
    "unsigned": int,
    "real": float,
    "reals": List[float],
    "text": str,
    "choice": str,
}


def python_name(name: str) -> str:
    return name.replace("-", "_")


def annotation(option: dict):
    kind = _TYPES.get(option["kind"], object)
    if option["repeatable"]:
        kind = Union[kind, List[kind]]
    return Optional[kind]


def signature(command: str, leading: list) -> inspect.Signature:
    """`leading` parameters, then every option of `command` as a keyword-only parameter whose
    default None leaves the method's own default."""
    params = list(leading)
    taken = {p.name for p in params}
    for o in _options(command):
        name = python_name(o["name"])
        if name in taken:
            continue
        taken.add(name)
        params.append(inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=None,
                                        annotation=annotation(o)))
    return inspect.Signature(params)


def help_section(command: str) -> str:
    """The options of `command` for a docstring: name, type, unit, range, the methods that take
    it with their defaults, and its help."""
    lines = []
    for o in _options(command):
        kind = o["kind"]
        if o["choices"]:
            kind = " | ".join(repr(c) for c in o["choices"])
        details = [kind]
        if o["unit"]:
            details.append(o["unit"])
        if o["range"]:
            details.append(o["range"])
        taken = ", ".join(m + (f": {d}" if d else "") + (f" in {r}" if r else "")
                          for m, d, r in o["methods"])
        lines.append(f"    {python_name(o['name'])} ({'; '.join(details)})"
                     + (f" [{taken}]" if taken else ""))
        lines.append(f"        {o['help']}")
    return "\n".join(lines)


_RANGE = re.compile(r"^([\[(])\s*([^,]+),\s*([^\])]+)([\])])$")


def _number(text: str) -> float:
    text = text.strip()
    if "^" in text:
        base, power = text.split("^")
        return float(base) ** float(power)
    return float(text)


def parse_range(text: str):
    """'[1, 4096]' or '(0, 1]' as (low, low_closed, high, high_closed); None when unbounded."""
    m = _RANGE.match(text.strip()) if text else None
    if not m:
        return None
    return _number(m.group(2)), m.group(1) == "[", _number(m.group(3)), m.group(4) == "]"

"""JSON text parsed with its nesting bounded first: a file or attribute nested thousands deep would otherwise exhaust
Python's recursion (``RecursionError``) before any check could name it. Every record reader of the project parses
through ``loads``."""

from __future__ import annotations

import json

#: the deepest nesting a record of the project holds (a fit summary: about 6 levels)
MAX_DEPTH = 32


def json_depth(text: str) -> int:
    """The deepest nesting of brackets in a JSON text (those inside strings counted too: an upper bound)."""
    depth = deepest = 0
    for char in text:
        if char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}":
            depth -= 1
    return deepest


def loads(text: str, where: str, max_depth: int = MAX_DEPTH, **options):
    """``json.loads(text, **options)``; ``ValueError`` of one line naming ``where`` for text nested deeper than
    ``max_depth``, text that is not JSON, or a number JSON cannot hold here (an integer of thousands of digits)."""
    if not isinstance(text, str):
        raise ValueError(f"{where} is not text")
    if json_depth(text) > max_depth:
        raise ValueError(f"{where} nests deeper than {max_depth} levels")
    try:
        return json.loads(text, **options)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{where} is not valid JSON ({exc.msg} at line {exc.lineno})") from None
    except RecursionError:
        raise ValueError(f"{where} nests too deep") from None
    except ValueError as exc:  # a number Python will not convert (an integer of more than 4300 digits)
        if type(exc) is not ValueError:  # a hook's own error (a repeated key of a parameter file)
            raise
        raise ValueError(f"{where} is not valid JSON ({str(exc).splitlines()[0][:80]})") from None

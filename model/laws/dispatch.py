"""The compiled dispatch over the registry, generated from its laws (``model.laws.law``): for each kind of part,
a chain that numba builds while it types the kernels, one link per law, each calling the parts that law's record
places (its ``Part``s, at their ``state_at`` and ``params_at``). No law is named here; a law added to the registry is
dispatched to without an edit.

``generated(kind, laws, neutral)`` gives a function ``f(code, args)`` for compiled code: law ``code``'s part(s) of
``kind`` called with ``*args, s, q``, or ``neutral(args)`` (Eq. 13's part) where the law defines none. The chain
compares the law's code once per link (seven integer comparisons at most); the kernels that call it cache as any
other (``model.kernel_cache`` keys them by the sources of every law).
"""

from __future__ import annotations

import numba
from numba.core import types
from numba.extending import overload

from .law import ONE, Law

#: the compilation of the dispatch's links: inlined into the kernels that call them (no cache of their own)
link = numba.njit(fastmath=False, nogil=True, error_model="numpy")


def _call(part, kind: str):
    """A link calling ``part``'s ``kind`` with the kernels' arguments and the part's place."""
    function, s, q = getattr(part.module, kind), part.state_at, part.params_at
    return link(lambda args: function(*args, s, q))


def _law_call(law: Law, kind: str, neutral):
    """Law ``law``'s ``kind``: its one defining part's (``ONE``), or each defining part's in turn, or ``neutral``."""
    parts = law.defining(kind)
    if not parts:
        return neutral
    if kind in ONE:
        return _call(parts[0], kind)
    chain = link(lambda args: None)
    for part in parts:
        one, before = _call(part, kind), chain

        def both(args, one=one, before=before):
            before(args)
            one(args)
        chain = link(both)
    return chain


def generated(kind: str, laws: tuple[Law, ...], neutral):
    """``f(code, args)`` for compiled code: ``kind`` of the law whose code is ``code`` (see the module)."""

    def from_law(k, code, args):
        raise NotImplementedError("compiled code only")

    @overload(from_law, prefer_literal=True)
    def _from_law(k, code, args):
        if not isinstance(k, types.IntegerLiteral):
            return None
        here = k.literal_value
        if here == len(laws):
            return lambda k, code, args: neutral(args)
        call, after = _law_call(laws[here], kind, neutral), here + 1

        def chain(k, code, args):
            if code == here:
                return call(args)
            return from_law(after, code, args)
        return chain

    def dispatch(code, args):
        raise NotImplementedError("compiled code only")

    @overload(dispatch)
    def _dispatch(code, args):
        return lambda code, args: from_law(0, code, args)

    return dispatch

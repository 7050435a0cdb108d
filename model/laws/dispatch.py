"""The compiled dispatch over the registry, generated from its laws (``model.laws.law``): for each kind of part, a
balanced tree of comparisons on the law's code that numba builds while it types the kernels, each leaf calling the
parts that law's record places (its ``Part``s, at their ``state_at`` and ``params_at``). No law is named here; a law
added to the registry is dispatched to without an edit.

``generated(kind, laws, neutral)`` gives a function ``f(code, args)`` for compiled code: law ``code``'s part(s) of
``kind`` called with ``*args, s, q``, or ``neutral(args)`` (Eq. 13's part) where the law defines none. Each level of
the tree is a call that hands the arguments on, so the tree is balanced (three levels for seven laws): a chain of one
link per law cost the laws at its end half their update rate (``docs/results/material-point.md``). The kernels that
call it cache as any other (``model.kernel_cache`` keys them by the sources of every law).
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
    chain = _call(parts[0], kind)
    if kind in ONE:
        return chain
    for part in parts[1:]:
        one, before = _call(part, kind), chain

        def both(args, one=one, before=before):
            before(args)
            one(args)
        chain = link(both)
    return chain


def generated(kind: str, laws: tuple[Law, ...], neutral):
    """``f(code, args)`` for compiled code: ``kind`` of the law whose code is ``code`` (see the module)."""

    def from_laws(lo, hi, code, args):
        raise NotImplementedError("compiled code only")

    @overload(from_laws, prefer_literal=True)
    def _from_laws(lo, hi, code, args):
        if not (isinstance(lo, types.IntegerLiteral) and isinstance(hi, types.IntegerLiteral)):
            return None
        first, end = lo.literal_value, hi.literal_value
        if end - first == 1:
            call = _law_call(laws[first], kind, neutral)
            return lambda lo, hi, code, args: call(args)
        middle = (first + end) // 2

        def split(lo, hi, code, args):
            if code < middle:
                return from_laws(first, middle, code, args)
            return from_laws(middle, end, code, args)
        return split

    def dispatch(code, args):
        raise NotImplementedError("compiled code only")

    @overload(dispatch)
    def _dispatch(code, args):
        count = len(laws)
        return lambda code, args: from_laws(0, count, code, args)

    return dispatch

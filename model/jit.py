"""The compilation every kernel of the model uses: numba, cached (``model.kernel_cache``), no fast-math (the results
must not depend on how the compiler reorders sums), no GIL (``model.update`` runs points on threads), and numpy's
error model: a division by zero gives inf or NaN, which the integrators report as a non-finite state in one line,
where Python's would raise ZeroDivisionError out of a compiled kernel."""

import numba

jit = numba.njit(cache=True, fastmath=False, nogil=True, error_model="numpy")
#: the same, inlined where it is called (numba IR): the stepper's small per-stage functions, whose calls with a dozen
#: arguments cost the material-point update about a quarter of its rate (``docs/results/material-point.md``)
inline = numba.njit(cache=True, fastmath=False, nogil=True, error_model="numpy", inline="always")

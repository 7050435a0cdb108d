"""The compilation every kernel of the model uses: numba, cached (``model.kernel_cache``), no fast-math (the results
must not depend on how the compiler reorders sums), no GIL (``model.update`` runs points on threads)."""

import numba

jit = numba.njit(cache=True, fastmath=False, nogil=True)

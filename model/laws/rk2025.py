"""Eq. 13 as written (paper Table 1): Lambda(S) A_jaumann = beta1 D' + beta2 |D'| A. It owns no parameter of its own;
its parts are the registry's defaults."""

NAME = "rk2025"
PARAMETERS = ()

"""Eq. 13 as written (paper Table 1): Lambda(S) A_jaumann = beta1 D' + beta2 |D'| A. It owns no parameter of its own;
its parts are the registry's defaults."""

NAME = "rk2025"
PARAMETERS = ()
#: Eq. 13 is the reference the others reduce to: checked as each law's neutral set, timed as the baseline
EXAMPLES = {"rk2025": {}}
FIT_EXAMPLE = {}
SPEED_EXAMPLE = {}
LEAVES_A_REVERSAL = True

"""The "elastic_compaction" law: the "elastic" law's jump over a finite strain and the "compaction" law's recovery held
back while the packing stays compacted, together. They act on different strains after a change of direction (the
jump within gamma_e ~ 0.01, the memory over 0.1-0.4; ``docs/results/models.md``) and on different parts of the
fabric (K, a part following D'/|D'|; N, the part of A that D' does not load), so each keeps its own parameters,
state and meaning:

    fabric = A + K,   K_jaumann = (sqrt2 / gamma_e) (kappa D'/|D'| - K) |D'|          ("elastic")
    beta2 |D'| removes A - (1 - g) N,   g = min(1, max(0, 1 - k (Phi - Phi_r)))        ("compaction")

kappa = 0 is the "compaction" law, k = 0 the "elastic" law, both zero Eq. 13. Objective, rate independent, bounded
and dissipative as each of the two is (``docs/model.md``).
"""

from . import compaction, elastic

NAME = "elastic_compaction"
#: the laws it joins: it owns their parameters and state in this order, and runs their parts (``model.laws.law``)
JOINS = (elastic.NAME, compaction.NAME)
#: the parameter sets every check of the registry runs this law with (``tests/unit/test_variants.py``), by name
EXAMPLES = {"elastic_compaction": {"elastic_fabric": -0.013, "elastic_strain": 0.01, "compaction_gain": 190.0,
                                   "compaction_strain": 0.8}}
#: the set the fit recovers from synthetic runs (``tests/unit/test_models.py``) and the one ``make bench`` times
FIT_EXAMPLE = {**elastic.FIT_EXAMPLE, **compaction.FIT_EXAMPLE}
SPEED_EXAMPLE = {**elastic.SPEED_EXAMPLE, **compaction.SPEED_EXAMPLE}
#: whether the law changes nothing in a reversal (where A stays in the plane of D')
LEAVES_A_REVERSAL = False

"""The values a user's choice may take, declared once in the standard library: the front door (``pipeline.targets``,
run by Debian's python3 before anything is installed) and the stages' parsers both read them."""

#: the components of tau/p a fit fits (``calibration.global_fit.STRESS_FITS``)
STRESSES = ("shear", "all")
#: how a protocol's runs share a fit (``calibration.global_fit.WEIGHTS``)
WEIGHTS = ("runs", "angles")
#: what a jackknife leaves out, one at a time
JACKKNIFE_OVER = ("seeds", "angles")
#: the definitions of strain, Phi and p a fit may be read in (``dataset.derived.Definitions``)
STRAINS = ("bulk", "nominal")
PHIS = ("central", "gap")
PRESSURES = ("target", "wall")
#: where a sweep's runs go
LAUNCHES = ("local", "slurm")

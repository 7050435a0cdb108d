"""Command-line options for the definitions a reader applies to a run (``derived.Definitions``)."""

from .derived import DEFAULT, Definitions


def add_definition_arguments(parser) -> None:
    """--strain, --phi, --pressure: the definitions the paper leaves open (``Definitions``)."""
    helps = {"strain": "strain measure: the central band's (bulk, default) or the paper's t*2U/H (nominal)",
             "phi": "packing fraction of the central region (default) or of the whole gap",
             "pressure": "tau over the controlled p (target, default) or over the measured wall stress"}
    for name, text in helps.items():
        parser.add_argument(f"--{name}", choices=Definitions.CHOICES[name], default=getattr(DEFAULT, name), help=text)


def definitions_from(args):
    """The ``Definitions`` of parsed ``add_definition_arguments`` options."""
    return Definitions(args.strain, args.phi, args.pressure)

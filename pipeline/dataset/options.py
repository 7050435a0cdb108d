"""Command-line options for the definitions a reader applies to a run (``derived.Definitions``)."""

from .derived import PAPER_DEFINITIONS, Definitions


def add_definition_arguments(parser, default: Definitions = PAPER_DEFINITIONS) -> None:
    """--strain, --phi, --pressure: the definitions the paper leaves open (``Definitions``), ``default`` the
    paper's own."""
    helps = {"strain": "strain measure: the paper's t*2U/H (nominal) or the central band's (bulk)",
             "phi": "packing fraction of the whole gap (gap) or of the central region (central)",
             "pressure": "tau over the controlled p (target) or over the measured wall stress (wall)"}
    for name, text in helps.items():
        value = getattr(default, name)
        parser.add_argument(f"--{name}", choices=Definitions.CHOICES[name], default=value,
                            help=f"{text}; default {value}")


def definitions_from(args):
    """The ``Definitions`` of parsed ``add_definition_arguments`` options."""
    return Definitions(args.strain, args.phi, args.pressure)

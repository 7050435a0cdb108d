"""What every pipeline command line shares: argparse with one-line errors."""

import argparse


class Parser(argparse.ArgumentParser):
    """argparse whose errors are one line (no usage dump) with exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def one_line_errors(main):
    """Decorate a command line's ``main``: a pipeline or model error becomes its one-line message on
    stderr and exit status 2."""
    import functools
    import sys

    import model

    from .errors import PipelineError

    @functools.wraps(main)
    def wrapped(argv=None) -> int:
        try:
            return main(argv)
        except (PipelineError, model.ParameterError, model.SolverError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2

    return wrapped


def add_definition_arguments(parser) -> None:
    """--strain, --phi, --pressure: the definitions the paper leaves open (``Definitions``)."""
    from .dataset.derived import DEFAULT, Definitions

    helps = {"strain": "strain measure: the central band's (bulk, default) or the paper's t*2U/H (nominal)",
             "phi": "packing fraction of the central region (default) or of the whole gap",
             "pressure": "tau over the controlled p (target, default) or over the measured wall stress"}
    for name, text in helps.items():
        parser.add_argument(f"--{name}", choices=Definitions.CHOICES[name], default=getattr(DEFAULT, name), help=text)


def definitions_from(args):
    """The ``Definitions`` of parsed ``add_definition_arguments`` options."""
    from .dataset.derived import Definitions

    return Definitions(args.strain, args.phi, args.pressure)

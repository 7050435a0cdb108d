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

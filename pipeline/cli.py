"""What every pipeline command line shares: argparse with one-line errors."""

import argparse
from pathlib import Path

from model.cli import printable


def given_path(text: str) -> Path:
    """A path option's value; an empty one would be the current folder, which no option means."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"{text!r} is empty: give a path")
    return Path(text)


class Parser(argparse.ArgumentParser):
    """argparse whose errors are one line (no usage dump) with exit status 2; every ``type=Path`` option refuses an
    empty value (``given_path``)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {printable(message)} (see --help)\n")

    def add_argument(self, *args, **kwargs):
        if kwargs.get("type") is Path:
            kwargs["type"] = given_path
        return super().add_argument(*args, **kwargs)


def one_line_errors(main):
    """Decorate a command line's ``main``: a pipeline or model error becomes its one-line message on
    stderr (``printable``: what a file or a user gave cannot act on the terminal) and exit status 2."""
    import functools
    import sys

    import model

    from .errors import PipelineError

    @functools.wraps(main)
    def wrapped(argv=None) -> int:
        try:
            return main(argv)
        except (PipelineError, model.ParameterError, model.SolverError) as exc:
            print(f"error: {printable(exc)}", file=sys.stderr)
            return 2

    return wrapped

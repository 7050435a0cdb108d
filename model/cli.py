"""Command line: ``python -m model predict --theta DEG --out FILE.csv`` and ``python -m model params``."""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from .kinematics import ROTATE_AT_STRAIN, HistoryError
from .params import VARIANTS, ParameterError, Params
from .solver import SolverError, predict

COMPONENTS = ((0, 0, "11"), (0, 1, "12"), (0, 2, "13"), (1, 1, "22"), (1, 2, "23"), (2, 2, "33"))
CSV_COLUMNS = (
    ["t_gd"] + [f"A{c}" for _, _, c in COMPONENTS] + [f"tau{c}" for _, _, c in COMPONENTS]
    + ["S", "phi", "w_shear", "w_vol"]
)


def _finite_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def _positive_float(text: str) -> float:
    value = _finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
    return value


def _strain_list(text: str) -> np.ndarray:
    items = [item for item in text.split(",") if item.strip()]
    if not items:
        raise argparse.ArgumentTypeError("expected a comma-separated list of strains")
    return np.array([_finite_float(item.strip()) for item in items])


def result_table(result) -> np.ndarray:
    """The CSV columns of ``CSV_COLUMNS`` as an (n, 17) array."""
    cols = [result.strain]
    cols += [result.A[:, i, j] for i, j, _ in COMPONENTS]
    cols += [result.tau[:, i, j] for i, j, _ in COMPONENTS]
    cols += [result.S, result.packing_fraction, result.w_shear, result.w_vol]
    return np.column_stack(cols)


MAX_PARAMS_BYTES = 65536  # a parameter file is a few hundred bytes


def _theta(text: str) -> float:
    value = _finite_float(text)
    if not -180 <= value <= 180:
        raise argparse.ArgumentTypeError(f"{text!r} must lie in [-180, 180] degrees (other angles repeat these)")
    return value


def printable(text: str) -> str:
    """``text`` with every character a terminal would act on (escape sequences, line breaks) written as its Python
    escape: an error echoing a value from a file or the command line stays one line of plain text."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


def check_output(path: Path) -> None:
    """Refuse, before any work, an output that is a link (renaming onto it would replace the link, as
    ``/dev/stdout``), a folder, a device, a FIFO or anything but a regular file, or that lies under a file."""
    if path.is_symlink():
        raise ParameterError(f"--out {path} is a link: give the name of a file of its own")
    if path.exists() and not path.is_file():
        kind = "a folder" if path.is_dir() else "not a regular file (a device, FIFO or socket)"
        raise ParameterError(f"--out {path} is {kind}: give a file name")
    existing = next(p for p in path.parents if p.exists())
    if not existing.is_dir():
        raise ParameterError(f"--out {path}: {existing} is a file, not a folder")


def atomic_write(path: Path, write) -> None:
    """``write(tmp)`` on a temporary file beside ``path``, then rename it onto ``path``: the file appears
    complete or not at all. The model stands alone (it imports nothing of ``pipeline``, whose ``io`` does the
    same for the pipeline's outputs), so its command line keeps this one writer of its own."""
    path = Path(path)
    check_output(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    mask = os.umask(0)
    os.umask(mask)
    os.fchmod(fd, 0o666 & ~mask)  # the file a plain open() would make, not mkstemp's owner-only one
    os.close(fd)
    tmp = Path(name)
    try:
        write(tmp)
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def load_params(path: str | Path) -> Params:
    """Parameters from a JSON file (``python -m model params``'s format); a one-line ``ParameterError``."""
    path = Path(path)
    try:
        if not path.is_file():
            raise ParameterError(f"{path}: not a regular file of parameters")
        with path.open("rb") as f:
            data = f.read(MAX_PARAMS_BYTES + 1)
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read parameters ({exc.strerror})") from None
    if len(data) > MAX_PARAMS_BYTES:
        raise ParameterError(f"{path}: more than {MAX_PARAMS_BYTES} bytes, not a parameter file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ParameterError(f"{path}: not UTF-8 text (byte {exc.start})") from None
    return Params.from_json(text, str(path))


def save_params(params: Params, path: str | Path, metadata: dict | None = None) -> None:
    """Write ``params`` (with ``metadata``, see ``Params.to_json``) atomically."""
    atomic_write(Path(path), lambda tmp: tmp.write_text(params.to_json(metadata)))


def write_csv(path: Path, table: np.ndarray) -> None:
    atomic_write(path, lambda tmp: np.savetxt(tmp, table, delimiter=",", header=",".join(CSV_COLUMNS),
                                              comments="", fmt="%.12g"))


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage dump)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {printable(message)} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="python -m model",
        description="Kinematic-hardening model of transient fabric and stress (Rojas & Kamrin 2025).",
    )
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    pred = sub.add_parser(
        "predict",
        help="write the converged periodic cycle of the Fig. 1 protocol as CSV",
        description=(
            "Converged periodic cycle: shear along e1 for 0 <= t*gamma_dot < ROTATE_AT, then along "
            "s = cos(theta) e1 + sin(theta) e3 up to the period 1.4. Columns: t_gd (strain from the start "
            "of a period), A_ij (fabric, Eq. 8), tau_ij (tau/p, Eq. 14, tension positive), S (Eq. 10), "
            "phi (packing fraction, Eq. 18), w_shear = tau:D' and w_vol = p Phi_dot/Phi per unit p*gamma_dot."
        ),
    )
    pred.add_argument("--theta", type=_theta, required=True, metavar="DEG",
                      help="rotation angle of the shear direction in degrees (paper: 30 ... 180)")
    pred.add_argument("--rotate-at", type=_positive_float, default=ROTATE_AT_STRAIN, metavar="STRAIN",
                      help="strain t*gamma_dot within the period at which the direction turns to theta "
                           "(default 0.7; Fig. 7 uses 0.1 and 0.2)")
    pred.add_argument("--params", type=Path, metavar="FILE.json",
                      help="model parameters as JSON with every key of `python -m model params` "
                           "(default: the paper's Table 2)")
    pred.add_argument("--times", type=_strain_list, metavar="t1,t2,...",
                      help="output strains within [0, 1.4], increasing (default: every 0.005)")
    pred.add_argument("--out", type=Path, required=True, metavar="FILE.csv", help="output CSV file")
    par = sub.add_parser("params", help="print the default parameters (Table 2) as JSON",
                         description="Print the default parameters (paper Table 2, Sec. 5) as JSON, or "
                                     "write them with --out, ready to edit and pass to --params.")
    par.add_argument("--variant", choices=list(VARIANTS), default="rk2025",
                     help="the fabric law (default rk2025, Eq. 13); its added parameters start at 0, where it is "
                          "Eq. 13")
    par.add_argument("--out", type=Path, metavar="FILE.json", help="write to this file instead of stdout")
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.out:
            check_output(args.out)
        if args.command == "params":
            chosen = Params(variant=args.variant)
            if args.out:
                save_params(chosen, args.out)
            else:
                sys.stdout.write(chosen.to_json())
            return 0
        params = load_params(args.params) if args.params else Params()
        result = predict(args.theta, rotate_at=args.rotate_at, params=params, times=args.times)
        write_csv(args.out, result_table(result))
        print(f"theta={args.theta:g} deg: cycle converged in {result.periods} periods "
              f"(residual {result.cycle_residual:.1e}), {len(result.strain)} rows -> {args.out}")
        return 0
    except (ParameterError, HistoryError, SolverError, OSError) as exc:
        print(f"python -m model: error: {printable(exc)}", file=sys.stderr)
        return 2

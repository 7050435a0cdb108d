"""What Make reads before it runs anything: ``results/.make/goals/`` (the goals' variables checked; the data set's
folder and the fit's suffix for fit, compare and figures) and a fit's ``options.txt`` stamp."""

from __future__ import annotations

import dataclasses
import hashlib
import time
from pathlib import Path

from ..errors import PipelineError
from ..variables import Variables
from .arguments import data_args, data_set_of, fit_options, fit_suffix
from .table import TARGETS, compare_seed

DATA_GOALS = ("fit", "compare", "compare-seed", "figures")


@dataclasses.dataclass(frozen=True)
class GoalValues:
    """What Make reads for the goals asked for (``results/.make/goals/``, each a file of plain text): the first bad
    value among the goals' variables, in one line (``CHECK_ERROR``: the Makefile's ``check`` stops on it before
    anything runs), and for fit, compare and figures the data set's folder and the fit's suffix, which their file
    rules need. No path found on disk is among them (the fit's ``options.txt`` stamps the runs), and the two names are
    checked against the folder pattern."""

    CHECK_ERROR: str = ""
    DATA_SET: str = ""
    FIT_SUFFIX: str = ""

    def stamp(self) -> str:
        """The text of ``goals.stamp``, which Make includes: a digest of the values, so that it changes with them."""
        digest = hashlib.sha256("\0".join(dataclasses.astuple(self)).encode()).hexdigest()[:16]
        return f"# the goals' values in results/.make/goals/ (python -m pipeline.targets makefile): {digest}\n"


def goal_values(v: Variables, goals: list[str]) -> GoalValues:
    """The ``GoalValues`` of ``goals`` under the variables ``v``."""
    from ..paths import check_folder_name

    try:
        for goal in goals:
            if goal not in DATA_GOALS:
                TARGETS[goal](v)
        if not set(goals) & set(DATA_GOALS):
            return GoalValues()
        fit_options_text(v)
        data_args(v)
        if "compare-seed" in goals:
            compare_seed(v)
        folder, suffix = data_set_of(v).folder, fit_suffix(v)
        check_folder_name(folder, "data set")
        if suffix:
            check_folder_name(suffix.lstrip("-"), "fit suffix")
        return GoalValues(DATA_SET=folder, FIT_SUFFIX=suffix)
    except PipelineError as exc:
        return GoalValues(CHECK_ERROR=" ".join(str(exc).split()))


def write_goal_values(stamp: Path, values: GoalValues) -> None:
    """Each value into ``<stamp's folder>/goals/<NAME>``, then the stamp (each rewritten only where it changed). Where
    a value's file held anything else (an older value, or one edited by hand), the stamp changes too, so that Make
    reads itself again with the values written."""
    changed = False
    for field in dataclasses.fields(values):
        path = stamp.parent / "goals" / field.name
        changed |= not (path.is_file() and path.read_text() == getattr(values, field.name))
        write_if_changed(path, getattr(values, field.name))
    text = values.stamp()
    if changed and stamp.is_file() and stamp.read_text() == text:
        text += f"# rewritten at {time.time_ns()}\n"
    write_if_changed(stamp, text)


def fit_options_text(v: Variables) -> str:
    """The options of ``make fit`` as one line (``results/<data set>/fit/options.txt``): a fit with other options
    is a new fit."""
    skip = v.whole("SKIP_CYCLES")
    return " ".join(fit_options(v) + (["--skip-cycles", skip] if skip else [])) + "\n"


def fit_stamp_text(v: Variables) -> str:
    """``options.txt``: the options of ``make fit`` (``fit_options_text``) and the SHA-256 of every run file that
    may belong to its data set, so that a changed run remakes the fit whatever its file time says."""
    from ..io import sha256
    from ..paths import preset_files, shown

    return fit_options_text(v) + "".join(f"{sha256(p)}  {shown(p)}\n" for p in preset_files(data_set_of(v).preset))


def write_if_changed(path: Path, text: str) -> None:
    """Rewrite ``path`` (atomically) only when its text changes, so that Make sees it changed only then; where it
    lands is checked first (``pipeline.io.check_output_path``: a regular file, nowhere a link leads out of
    ``results/`` or into ``data/``; its folder a folder, writable)."""
    from ..io import atomic_path, check_output_path, check_writable_dir

    check_output_path(path)
    check_writable_dir(path.parent)
    if path.is_file() and path.read_text() == text:
        return
    with atomic_path(path) as tmp:  # a temporary of its own: two makes at once never share one
        tmp.write_text(text)

"""What Make reads before it runs anything: ``results/.make/goals.mk`` (the goals' variables checked; the data set's
folder and run files for fit, compare and figures) and a fit's ``options.txt`` stamp."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import PipelineError
from ..variables import Variables
from .arguments import data_args, data_set_of, fit_options, fit_suffix
from .table import TARGETS, compare_seed

DATA_GOALS = ("fit", "compare", "compare-seed", "figures")


def goals_makefile(v: Variables, goals: list[str]) -> str:
    """``results/.make/goals.mk``: CHECK_ERROR, the first bad value among the goals' variables (the Makefile's
    ``check`` stops on it, in one line, before anything runs); else, for fit, compare and figures, the data set's
    folder (DATA_SET) and the fit's suffix (FIT_SUFFIX), which their file rules need. No path found on disk is
    written (the fit's ``options.txt`` stamps the runs): only these two names, checked against the folder pattern."""
    from ..paths import check_folder_name

    lines = [f"# the goals {' '.join(goals)}, their variables checked (python -m pipeline.targets makefile)"]
    try:
        for goal in goals:
            if goal not in DATA_GOALS:
                TARGETS[goal](v)
        if set(goals) & set(DATA_GOALS):
            fit_options_text(v)
            data_args(v)
            if "compare-seed" in goals:
                compare_seed(v)
            folder, suffix = data_set_of(v).folder, fit_suffix(v)
            check_folder_name(folder, "data set")
            if suffix:
                check_folder_name(suffix.lstrip("-"), "fit suffix")
            lines += [f"DATA_SET := {folder}", f"FIT_SUFFIX := {suffix}"]
    except PipelineError as exc:
        text = " ".join(str(exc).split()).replace("$", "$$").replace("#", "\\#").rstrip("\\")
        lines.append(f"CHECK_ERROR := {text}")
    return "\n".join(lines) + "\n"


def fit_options_text(v: Variables) -> str:
    """The options of ``make fit`` as one line (``results/<data set>/fit/options.txt``): a fit with other options
    is a new fit."""
    skip = v.whole("SKIP_CYCLES")
    return " ".join(fit_options(v) + (["--skip-cycles", skip] if skip else [])) + "\n"


def fit_stamp_text(v: Variables) -> str:
    """``options.txt``: the options of ``make fit`` (``fit_options_text``) and the SHA-256 of every run file that
    may belong to its data set, so that a changed run remakes the fit whatever its file time says."""
    from ..dataset.manifest import sha256
    from ..paths import preset_files, shown

    return fit_options_text(v) + "".join(f"{sha256(p)}  {shown(p)}\n" for p in preset_files(data_set_of(v).preset))


def write_if_changed(path: Path, text: str) -> None:
    """Rewrite ``path`` (atomically) only when its text changes, so that Make sees it changed only then."""
    if path.is_file() and path.read_text() == text:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)

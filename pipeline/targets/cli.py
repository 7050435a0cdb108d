"""The front door's command line: ``python -m pipeline.targets [--plan] TARGET``, ``makefile FILE GOAL...`` and
``fit-options FILE`` (see the package's text)."""

from __future__ import annotations

import os
import runpy
import sys
from collections.abc import Mapping
from pathlib import Path

from ..errors import PipelineError
from ..variables import Variables
from .arguments import data_set_of
from .goals import DATA_GOALS, fit_stamp_text, goal_values, write_goal_values, write_if_changed
from .table import TARGETS, Call


def say_data_set(v: Variables) -> None:
    chosen = data_set_of(v)
    how = "" if v.name("PRESET") else ", the most faithful one with a reversal run; PRESET=... to choose"
    print(f"data set {chosen.folder} (preset {chosen.preset}{how})", flush=True)


#: the targets that name the data set they read before they start
SAYS_DATA_SET = {"fit", "fit-bootstrap", "fit-jackknife", "fit-angles", "fit-definitions", "fit-from", "fit-profile"}


def run(calls: list[Call]) -> int:
    """Each stage as ``python -m <module> <argv>`` would run it, in this process; the first failure stops."""
    for call in calls:
        sys.argv = [call.module, *call.argv]
        try:
            runpy.run_module(call.module, run_name="__main__", alter_sys=True)
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) or stop.code is None else 1
            if stop.code not in (None, 0):
                if not isinstance(stop.code, int):
                    print(stop.code, file=sys.stderr)
                return code
    return 0


def stamp(name: str, write) -> int:
    """``write(Path(name))``, one of the files Make reads (the goals' values, a fit's stamp); a refusal or a folder
    that cannot take it is one line and exit status 2."""
    try:
        write(Path(name))
    except PipelineError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"error: cannot write {name} ({exc.strerror or exc}): make its folder a writable folder", file=sys.stderr)
        return 2
    return 0


def main(argv: list[str] | None = None, environ: Mapping[str, str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    v = Variables(os.environ if environ is None else environ)
    if argv[:1] == ["makefile"] and len(argv) >= 2 and all(g in TARGETS or g in DATA_GOALS for g in argv[2:]):
        return stamp(argv[1], lambda path: write_goal_values(path, goal_values(v, argv[2:])))
    plan = argv[:1] == ["--plan"]
    rest = argv[1:] if plan else argv
    if rest[:1] == ["fit-options"] and len(rest) == 2:
        return stamp(rest[1], lambda path: write_if_changed(path, fit_stamp_text(v)))
    if len(rest) != 1 or rest[0] not in TARGETS:
        print(f"usage: python -m pipeline.targets [--plan] TARGET (one of {', '.join(TARGETS)}), or makefile FILE "
              "[GOAL ...]", file=sys.stderr)
        return 2
    try:
        calls = TARGETS[rest[0]](v)
        if plan:
            print("\n".join(map(str, calls)))
            return 0
        if rest[0] in SAYS_DATA_SET:
            say_data_set(v)
    except PipelineError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return run(calls)


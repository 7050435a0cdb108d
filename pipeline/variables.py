"""The user's make variables, each read with the check of its kind (standard library only: Debian's python3 runs the
front door, ``pipeline.targets``, before anything is installed). A check stops injection and reads the shape of a
value (a number, a name, a list); what a value means the stage that takes it checks, once."""

from __future__ import annotations

import re
from collections.abc import Mapping

from dem.lammps import settings

from .engines import ENGINES as ENGINE_REGISTRY
from .errors import PipelineError

ENGINES = tuple(ENGINE_REGISTRY)

#: what a flag variable (FRESH=1) may say
YES, NO = ("1", "yes", "true"), ("", "0", "no", "false")
_NUMBER = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")
_WHOLE = re.compile(r"[0-9]{1,9}")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
_SETTING = re.compile(r"[A-Za-z_][A-Za-z0-9_]*=[A-Za-z0-9_.:+-]+")
_DATA_SET = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*(/[A-Za-z0-9_.=+-]+)*")
_PATH = re.compile(r"[A-Za-z0-9_./-]+")

#: the longest value a make variable may hold (a long list of seeds or settings stays far below)
MAX_VALUE = 1000


class Variables:
    """The user's make variables (an environment), each read with the check of its kind; an empty one is not given."""

    def __init__(self, environ: Mapping[str, str]):
        self._environ = environ

    def text(self, name: str) -> str | None:
        value = self._environ.get(name, "")
        if len(value) > MAX_VALUE:
            raise PipelineError(f"{name}={value[:20]!r}... is {len(value)} characters long: no value needs more than "
                                f"{MAX_VALUE}")
        if "\n" in value or "\r" in value:
            raise PipelineError(f"{name}={value!r} holds a line break: give it on one line")
        return value if value.strip() else None

    def _one(self, name: str, pattern: re.Pattern, what: str, default: str | None) -> str | None:
        value = self.text(name)
        if value is None:
            return default
        if not pattern.fullmatch(value.strip()):
            raise PipelineError(f"{name}={value!r} is not {what}")
        return value.strip()

    def _many(self, name: str, pattern: re.Pattern, what: str, sep: str | None = None) -> list[str]:
        value = self.text(name)
        if value is None:
            return []
        words = [w.strip() for w in value.split(sep)] if sep else value.split()
        if not all(pattern.fullmatch(w) for w in words):
            raise PipelineError(f"{name}={value!r} is not {what}")
        return words

    def number(self, name: str, default: str | None = None) -> str | None:
        return self._one(name, _NUMBER, "a number", default)

    def whole(self, name: str, default: str | None = None) -> str | None:
        return self._one(name, _WHOLE, "a whole number", default)

    def name(self, name: str, default: str | None = None) -> str | None:
        return self._one(name, _NAME, "a name (letters, digits, _ . -)", default)

    def choice(self, name: str, choices: tuple[str, ...], default: str | None = None) -> str | None:
        value = self.text(name)
        if value is None:
            return default
        if value.strip() not in choices:
            raise PipelineError(f"{name}={value!r} is not {' or '.join(choices)}")
        return value.strip()

    def flag(self, name: str) -> bool:
        value = (self.text(name) or "").strip().lower()
        if value not in YES + NO:
            raise PipelineError(f"{name}={self.text(name)!r} is not 1 or empty")
        return value in YES

    def numbers(self, name: str) -> list[str]:
        return self._many(name, _NUMBER, "a list of numbers")

    def wholes(self, name: str) -> list[str]:
        return self._many(name, _WHOLE, "a list of whole numbers")

    def settings(self, name: str) -> list[str]:
        return self._many(name, _SETTING, "a list of key=value")

    def names(self, name: str, choices: tuple[str, ...] | None = None) -> list[str]:
        words = self._many(name, _NAME, "a comma-separated list of names", sep=",")
        if choices and not set(words) <= set(choices):
            raise PipelineError(f"{name}={self.text(name)!r} is not a comma-separated list of {', '.join(choices)}")
        return words

    def presets_engines(self, name: str) -> list[str]:
        pattern = re.compile(_NAME.pattern + "(:(" + "|".join(map(re.escape, ENGINES)) + "))?")
        return self._many(name, pattern, f"a list of PRESET[:ENGINE] (engines: {', '.join(ENGINES)})")

    def data_set(self, name: str) -> str | None:
        return self._one(name, _DATA_SET, "a data set (preset[/engine][/key=value...])", None)

    def path(self, name: str) -> str | None:
        return self._one(name, _PATH, "a run folder (letters, digits, _ . - /)", None)

    def lammps_settings(self, name: str, default: str) -> str:
        """LAMMPS commands separated by ``;``, each one that sets how LAMMPS runs (``dem.lammps.settings``), never one
        that runs a program or reads a file."""
        value = self.text(name)
        if value is None:
            return default
        try:
            settings.parse(value, name)
        except ValueError as exc:
            raise PipelineError(str(exc)) from None
        return value

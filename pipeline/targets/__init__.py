"""The user's make targets: Make hands their variables over as text, this package checks them, then calls the stages.

The Makefile turns every variable a user may set (``USER_VARIABLES`` there) into plain text that is never expanded
again, exports it, and never writes it into a recipe. ``python -m pipeline.targets TARGET`` reads those variables
from the environment, checks each one a target uses (one line naming the value, before any work) and runs the
target's stages in this process with argument lists, as ``python -m <stage> <arguments>`` would: no shell ever sees
a user's value. ``--plan`` prints the stages' command lines and runs nothing. ``makefile FILE GOAL...`` writes the
Makefile's values of the goals asked for (``goal_values``); Debian's ``python3`` runs it before anything is
installed, so this package imports the standard library only (the stages are imported when they run). Modules:
``table`` (each target's stages), ``arguments`` (what the targets hand the stages), ``goals`` (what Make reads
first), ``cli``; the variables' checks are ``pipeline.variables``, the choices ``pipeline.choices``.
"""

from ..variables import Variables
from .cli import main
from .goals import GoalValues, goal_values, write_goal_values, write_if_changed
from .table import TARGETS, Call

__all__ = ["TARGETS", "Call", "GoalValues", "Variables", "goal_values", "main", "write_goal_values", "write_if_changed"]

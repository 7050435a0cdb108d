"""The scene that Yade's controller drives.

A PyRunner's command is a string that Yade runs in ``__main__``, whatever script that is (the scene, the
benchmark, the profiler); it cannot hold a reference. So the scene that is running registers itself here
(``activate``) and the command reaches it by this module's import path: the one hand-off between Yade and
the scene object, and the only module-level state of a run.
"""

SCENE = None
COMMAND = "import dem.yade.active; dem.yade.active.SCENE.control()"


def activate(scene):
    """Make ``scene`` the one the controller drives."""
    global SCENE
    SCENE = scene

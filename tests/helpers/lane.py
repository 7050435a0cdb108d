"""``python tests/helpers/lane.py FOLDER OWNER``: run the lane's commands (``FOLDER/commands.json``) one after the
other in ``FOLDER/project``, each in a process group of its own; append each one's record to
``FOLDER/done.jsonl``; mark ``FOLDER/ended`` after the last, or after the first that fails. When process ``OWNER``
(the test session) is gone, the running command's group is killed and the lane ends."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def run(args: list[str], project: Path, owner: int) -> tuple[int, str, float] | None:
    """One command's exit status, output and wall time (s); None if the owner went first (the command killed)."""
    tic = time.monotonic()
    out = project.parent / "output.txt"
    with open(out, "w") as sink:
        proc = subprocess.Popen(["make", "--no-print-directory", *args], cwd=project,
                                stdout=sink, stderr=subprocess.STDOUT, process_group=0)
        while proc.poll() is None:
            if not alive(owner):
                os.killpg(proc.pid, signal.SIGTERM)
                proc.wait()
                return None
            time.sleep(0.5)
    return proc.returncode, out.read_text(errors="replace"), time.monotonic() - tic


def main(folder: Path, owner: int) -> int:
    project = folder / "project"
    for args in json.loads((folder / "commands.json").read_text()):
        done = run(args, project, owner)
        if done is None:
            return 1
        status, output, seconds = done
        with open(folder / "done.jsonl", "a") as records:
            records.write(json.dumps({"args": args, "status": status, "output": output, "seconds": seconds}) + "\n")
        if status != 0:
            break
    (folder / "ended").touch()
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]), int(sys.argv[2])))

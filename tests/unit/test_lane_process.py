"""The suite's lane of long targets as a process of its own (``tests/helpers/lane.py``): it runs its commands in
order, records each, stops at the first that fails, and ends its running command and itself once the session's
process is gone (a killed `make test` leaves no DEM run behind)."""

import json
import os
import subprocess
import sys
import time

from pipeline.paths import ROOT
from tests.helpers.project import LANE_SCRIPT

MAKEFILE = "quick:\n\t@echo quick done\nfails:\n\t@exit 3\nlong:\n\t@sleep 60\n"


def lane_in(folder, commands, owner):
    (folder / "project").mkdir(parents=True)
    (folder / "project" / "Makefile").write_text(MAKEFILE)
    (folder / "commands.json").write_text(json.dumps(commands))
    return subprocess.Popen([sys.executable, str(LANE_SCRIPT), str(folder), str(owner)], cwd=ROOT)


def records(folder):
    done = folder / "done.jsonl"
    return [json.loads(line) for line in done.read_text().splitlines()] if done.exists() else []


def sleepers(folder):
    """The `sleep 60` processes the lane's `make long` started (their working folder is the lane's project)."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            if os.readlink(f"/proc/{pid}/cwd") == str(folder / "project") and \
                    open(f"/proc/{pid}/cmdline", "rb").read().startswith(b"sleep"):
                found.append(int(pid))
        except OSError:
            continue
    return found


def test_the_lane_records_each_command_and_stops_at_the_first_failure(tmp_path):
    lane = lane_in(tmp_path, [["quick"], ["fails"], ["quick"]], os.getpid())
    assert lane.wait(timeout=30) == 0
    done = records(tmp_path)
    assert [(r["args"], r["status"]) for r in done] == [(["quick"], 0), (["fails"], 2)]
    assert "quick done" in done[0]["output"] and (tmp_path / "ended").exists()


def test_the_lane_ends_its_command_and_itself_when_the_session_is_gone(tmp_path):
    owner = subprocess.Popen(["sleep", "60"])
    lane = lane_in(tmp_path, [["quick"], ["long"], ["quick"]], owner.pid)
    deadline = time.monotonic() + 20
    while not sleepers(tmp_path):
        assert time.monotonic() < deadline and lane.poll() is None, "the lane never reached its long command"
        time.sleep(0.1)
    owner.kill()
    owner.wait()
    assert lane.wait(timeout=10) == 1
    assert [r["args"] for r in records(tmp_path)] == [["quick"]] and not (tmp_path / "ended").exists()
    deadline = time.monotonic() + 5
    while sleepers(tmp_path):
        assert time.monotonic() < deadline, "the lane's command outlived the session"
        time.sleep(0.1)

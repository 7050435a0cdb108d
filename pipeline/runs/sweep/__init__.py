"""Sweeps: a set of DEM runs (angles x rotations x seeds of one preset) launched with one command.

``python -m pipeline.runs.sweep run --preset P --thetas "30 60 90" [--rotate-ats ...] [--seeds "1 2"]
[--set key=value ...] [--launch local|slurm] [--slurm key=value ...]`` (``make sweep``) plans the runs,
checks every one of them (and the scheduler's settings) before anything starts, writes the plan to
``results/sweeps/<id>/`` and launches the runs that are not done:

- ``local``: a makefile of one rule per run, run by Make with ``-j`` (``[local] jobs``, one Yade
  thread each); a finished run is never rerun, an interrupted one resumes from its checkpoint.
- ``slurm``: one job array (``sbatch --array``), each task running exactly the launcher of
  ``make dem`` (``python -m pipeline.runs run``) into the same ``results/`` tree. Tasks are submitted
  with ``--requeue`` and ``--signal=B:USR1@<lead>``: on the signal the run stops at its next
  checkpoint and the task requeues itself, so it resumes bit-identically (one thread). A task whose
  process is killed is requeued the same way, at most ``max_requeues`` times; a run that stops with
  the DEM's diagnostic (exit 3) or cannot be resumed (exit 2) is not requeued: it is failed, with its
  reason in ``<run>.run/failed.json``.

``status`` (``make sweep-status``) tabulates every run of a sweep: done, running (progress and ETA from
the run's own progress line), queued (with the scheduler's reason), failed (with the reason), stopped
(resumable) or not started, from the run folders and one ``squeue`` call.
"""

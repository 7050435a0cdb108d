#!/bin/bash
@DIRECTIVES@

# Each task runs the launcher of `make dem` on one run of the sweep (@SWEEP@).
# SIGUSR1 (@LEAD@ s before the time limit): the run stops at its next checkpoint and
# the task requeues itself; it resumes from that checkpoint, bit-identically at one thread.
cd @ROOT@
mapfile -t ARGS < @TASKS@/"$SLURM_ARRAY_TASK_ID".args
echo "task $SLURM_ARRAY_TASK_ID, attempt $(( ${SLURM_RESTART_COUNT:-0} + 1 )) on $(hostname): ${ARGS[*]}"
@PYTHON@ -m pipeline.runs run "${ARGS[@]}" --results @RESULTS@ --threads @THREADS@ --ranks @RANKS@ &
child=$!
trap 'kill -USR1 "$child" 2>/dev/null' USR1
status=0
while kill -0 "$child" 2>/dev/null; do wait "$child"; status=$?; done
case $status in
  0) echo "task $SLURM_ARRAY_TASK_ID: done"; exit 0 ;;
  130|137|138|143) ;;  # stopped by a signal (the time limit's USR1, a preemption): resumable, requeued below
  *) echo "task $SLURM_ARRAY_TASK_ID: failed (exit $status), not requeued (see failed.json in the run folder)"
     exit "$status" ;;
esac
if [ "${SLURM_RESTART_COUNT:-0}" -lt @MAX_REQUEUES@ ]; then
  echo "task $SLURM_ARRAY_TASK_ID: stopped (exit $status); requeued to resume from its checkpoint"
  scontrol requeue "${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID}"
else
  echo "task $SLURM_ARRAY_TASK_ID: stopped (exit $status) after @MAX_REQUEUES@ requeues; not requeued"
fi
exit "$status"

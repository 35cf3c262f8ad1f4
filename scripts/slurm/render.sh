#!/usr/bin/env bash
# Render a scene on a Slurm cluster in N shards and merge them into one image:
#
#   render.sh [--wait] [--parts DIR] [--cpus C] [--shard-sbatch OPT]... [--merge-sbatch OPT]...
#             SCENE N OUT [raylab render flags...]
#
# Submits a job array of N tasks (shard.sbatch: task I renders shard I/N into DIR/part-I.exr,
# checkpointing to DIR/part-I.ckpt) and a merge job (merge.sbatch) that runs once every task
# has succeeded (--dependency=afterok) and writes OUT. Prints both job ids.
#
#   --wait        block until the merge job ends, print its log, exit with its status (and
#                 fail if OUT is not there). If a shard fails the merge can never run: the
#                 failed tasks are listed and the merge job is cancelled, exit 1.
#   --parts DIR   folder for parts, checkpoints and Slurm logs (default: OUT.parts beside OUT)
#   --cpus C      cpus per shard task, passed to raylab as --threads (default 1)
#   --shard-sbatch OPT, --merge-sbatch OPT
#                 one more sbatch option for the shard array, or for the merge job only
#                 (repeat for several; `--merge-sbatch=--mem=64G` also works), e.g. a partition
#                 with more memory for the merge, or where each may run:
#                 --shard-sbatch --exclude=node3 --merge-sbatch --nodelist=node3
#
# The cluster's file systems must show SCENE, DIR, OUT and the raylab binary at the same paths
# as here. RAYLAB names the binary (default: `raylab` on PATH), made an absolute path.
# Other sbatch settings: edit the #SBATCH lines of shard.sbatch/merge.sbatch, or use sbatch's
# input environment variables (SBATCH_PARTITION, SBATCH_ACCOUNT, SBATCH_TIMELIMIT, ...), which
# apply to both jobs.
#
# The parts folder is stamped with the render (DIR/render.stamp: the scene file and a hash of
# its contents, N, OUT, the raylab flags). A folder stamped by another render is refused (exit
# 2, both stamps printed); the same render submitted again goes on from its checkpoints.
#
# Before submitting anything it asks what every task would refuse, and exits 2 if so: OUT
# must be .png or .exr and none of the parts; the folders must take a file; and `raylab render
# --check` runs each task's command line that can be told apart here (shard 0, and every
# shard with a checkpoint to resume) up to where it would start rendering: the scene and the
# files it reads, the integrator and its parameters, more shards than blocks of 8 passes (or
# rows of tiles), flags the script sets itself (-o, --shard, --checkpoint, --threads, given
# twice) or that shards refuse (--time, --watch), a checkpoint of another render.
# RAYLAB_SLURM_CHECK=no skips the last (e.g. when this node has less memory than the
# cluster's).
#
# Exit codes: 0 submitted (or, with --wait, merged); 2 bad arguments; 1 a submission failed
# or, with --wait, a shard failed; otherwise the merge job's exit code.
#
# RAYLAB_SLURM_POLL (seconds, default 2) sets how often --wait asks Slurm; it gives up (exit 1,
# the jobs go on) when the controller has not answered for RAYLAB_SLURM_GIVE_UP seconds
# (default 300). Setting
# RAYLAB_SLURM_KILL_INVALID_DEP=no submits the merge without --kill-on-invalid-dep=yes (it then
# stays pending, reason DependencyNeverSatisfied, when a shard fails; --wait cancels it).
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
POLL=${RAYLAB_SLURM_POLL:-2}

usage() {
  sed -n '2,/^set -euo/{/^set -euo/d;s/^# \{0,1\}//;p}' "${BASH_SOURCE[0]}"
}
bad() {
  echo "render.sh: $*" >&2
  echo "usage: render.sh [--wait] [--parts DIR] [--cpus C] [--shard-sbatch OPT]... [--merge-sbatch OPT]... SCENE N OUT [raylab render flags...]" >&2
  exit 2
}
# (At most 6 digits: bash's arithmetic wraps around past 2^63, and raylab takes N <= 100000.)
is_count() { [[ $1 =~ ^[0-9]{1,6}$ ]] && [ "$((10#$1))" -ge 1 ]; }
# An absolute path for $1 (which need not exist yet); symlinks are kept as they are.
absolute() { case "$1" in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }

# ---- arguments -------------------------------------------------------------------------
wait=0 parts="" cpus=1 shard_sbatch=() merge_sbatch=()
while [ $# -gt 0 ]; do
  case "$1" in
    --wait) wait=1; shift ;;
    --parts) [ $# -ge 2 ] || bad "--parts needs a folder"; parts=$2; shift 2 ;;
    --parts=*) parts=${1#*=}; shift ;;
    --cpus) [ $# -ge 2 ] || bad "--cpus needs a number"; cpus=$2; shift 2 ;;
    --cpus=*) cpus=${1#*=}; shift ;;
    --shard-sbatch | --merge-sbatch)
      [ $# -ge 2 ] && [ -n "$2" ] || bad "$1 needs an sbatch option, e.g. $1 --exclude=node3"
      if [ "$1" = --shard-sbatch ]; then shard_sbatch+=("$2"); else merge_sbatch+=("$2"); fi
      shift 2 ;;
    --shard-sbatch=?*) shard_sbatch+=("${1#*=}"); shift ;;
    --merge-sbatch=?*) merge_sbatch+=("${1#*=}"); shift ;;
    -h | --help) usage; exit 0 ;;
    --) shift; break ;;
    -*) bad "unknown option $1 (options come before SCENE N OUT; raylab flags after them)" ;;
    *) break ;;
  esac
done
[ $# -ge 3 ] || bad "needs SCENE N OUT"
scene=$1 shards=$2 out=$3
shift 3
flags=("$@") # the rest goes to every `raylab render`

[ -f "$scene" ] || bad "scene file '$scene' does not exist"
is_count "$shards" || bad "N must be a positive integer (the number of shards), not '$shards'"
is_count "$cpus" || bad "--cpus must be a positive integer, not '$cpus'"
shards=$((10#$shards)) cpus=$((10#$cpus))
[ "$shards" -le 100000 ] || bad "N must be at most 100000 (raylab's --shard limit), not $shards"
[ -n "$out" ] || bad "OUT is empty"
[ ! -d "$out" ] || bad "OUT '$out' is a folder: give the merged image's file name"
out_name=${out##*/}
case "${out_name,,}" in
  ?*.png | ?*.exr) ;;
  *) bad "OUT '$out' must end in .png or .exr: raylab merge writes nothing else" ;;
esac

RAYLAB=${RAYLAB:-raylab}
if [[ $RAYLAB != */* ]]; then
  found=$(command -v -- "$RAYLAB" || true)
  [ -n "$found" ] || bad "'$RAYLAB' is not on PATH: set RAYLAB=/path/to/raylab"
  RAYLAB=$found
fi
RAYLAB=$(absolute "$RAYLAB")
[ -f "$RAYLAB" ] && [ -x "$RAYLAB" ] || bad "RAYLAB '$RAYLAB' is not an executable file"
command -v sbatch >/dev/null || { echo "render.sh: sbatch not found: is this a Slurm login node?" >&2; exit 1; }

SCENE=$(absolute "$scene")
OUT=$(absolute "$out")
PARTS=$(absolute "${parts:-$out.parts}")
PARTS=${PARTS%/}
# The merge refuses to write over one of its own parts.
if [ "$(realpath -m -- "$(dirname "$OUT")")" = "$(realpath -m -- "$PARTS")" ] \
  && [[ ${OUT##*/} =~ ^part-[0-9]+\.[eE][xX][rR]$ ]]; then
  bad "OUT '$OUT' is one of the parts in '$PARTS': choose another name or --parts"
fi
for d in "$PARTS" "$(dirname "$OUT")"; do
  mkdir -p -- "$d" 2>/dev/null || bad "cannot make the folder '$d'"
  # A real write: -w says yes to root on a read-only or root-squashed file system.
  t=$(mktemp "$d/.render-sh.XXXXXX" 2>/dev/null) \
    || bad "cannot write into '$d': the jobs could not write their logs, parts or image there"
  rm -f -- "$t"
done

# The parts folder's stamp: what this render is (the scene file and its contents, N, OUT and
# the raylab flags; not --cpus, which does not change the image). A folder stamped by another
# render is refused: its parts and checkpoints are that render's, and two renders writing
# part-I.exr into one folder would overwrite each other's. The same render submitted again (a
# shard failed, the jobs were cancelled) finds its own stamp and goes on from its checkpoints.
# A folder without a stamp (made before stamps, or by hand) is taken and stamped; its
# checkpoints are still checked below.
STAMP="$PARTS/render.stamp"
scene_sum=$(sha256sum <"$SCENE") || bad "cannot read the scene file '$SCENE'"
stamp=$(
  printf 'raylab render.sh stamp, format 1\n'
  printf 'scene %s\n' "$SCENE"
  printf 'scene sha256 %s\n' "${scene_sum%% *}"
  printf 'shards %s\n' "$shards"
  printf 'out %s\n' "$OUT"
  printf 'flags'
  [ ${#flags[@]} = 0 ] || printf ' %q' "${flags[@]}"
  printf '\n'
)
if [ -e "$STAMP" ] || [ -L "$STAMP" ]; then
  [ -f "$STAMP" ] && [ ! -L "$STAMP" ] \
    || bad "'$STAMP' is not a regular file: remove it, or give another --parts"
  if [ "$(cat -- "$STAMP")" != "$stamp" ]; then
    {
      echo "render.sh: the parts folder '$PARTS' belongs to another render; its stamp says:"
      sed 's/^/    /' -- "$STAMP"
      echo "  and this render is:"
      sed 's/^/    /' <<<"$stamp"
    } >&2
    bad "the parts folder '$PARTS' belongs to another render (above): give another --parts or OUT, or remove the folder"
  fi
fi

# What every task would refuse, asked of raylab itself: shard 0's command line, and that of
# every shard with a checkpoint to resume (one of another render is refused), as shard.sbatch
# runs them, with --check (raylab checks, writes nothing, exits 0 when it would render), on
# one thread: a task's --threads C is checked against the cores of the node it runs on.
if [ "${RAYLAB_SLURM_CHECK:-yes}" != no ]; then
  check_task() {
    local task=$1 resume=()
    [ -e "$PARTS/part-$task.ckpt" ] && resume=(--resume)
    local msg
    if ! msg=$("$RAYLAB" render "$SCENE" --shard "$task/$shards" -o "$PARTS/part-$task.exr" \
      --threads 1 --checkpoint "$PARTS/part-$task.ckpt" "${resume[@]}" "${flags[@]}" \
      --check 2>&1 >/dev/null); then
      printf '%s\n' "$msg" >&2
      bad "raylab refuses shard $task/$shards (above): every task would fail; nothing submitted (RAYLAB_SLURM_CHECK=no skips this check)"
    fi
  }
  check_task 0
  for ckpt in "$PARTS"/part-*.ckpt; do
    [ -e "$ckpt" ] || continue
    task=${ckpt##*/part-}
    task=${task%.ckpt}
    [[ $task =~ ^[0-9]+$ ]] && [ "$task" != 0 ] && [ "$task" -lt "$shards" ] && check_task "$task"
  done
fi
# Stamped before the jobs exist, so that another render.sh pointed at this folder while they
# run is refused. Written whole into a temporary file, then linked to its name: `ln` fails if
# the name exists, so of two render.sh stamping an empty folder at once only one wins, and
# the other compares. (Where the file system has no hard links, it is moved into place.)
if [ ! -e "$STAMP" ]; then
  t=$(mktemp "$PARTS/.render-stamp.XXXXXX") && printf '%s\n' "$stamp" >"$t" \
    || bad "cannot write the stamp '$STAMP'"
  if ! ln -- "$t" "$STAMP" 2>/dev/null; then
    if [ -e "$STAMP" ]; then
      [ "$(cat -- "$STAMP")" = "$stamp" ] \
        || { rm -f -- "$t"; bad "another render stamped the parts folder '$PARTS' just now: give another --parts"; }
    else
      mv -f -- "$t" "$STAMP" || bad "cannot write the stamp '$STAMP'"
    fi
  fi
  rm -f -- "$t"
fi
SHARDS=$shards
# The jobs get these through the environment (sbatch's default --export=ALL), not through
# --export=NAME=VALUE, which cannot carry a value holding a comma.
export RAYLAB SCENE SHARDS PARTS OUT

# ---- submit ------------------------------------------------------------------------------
# --parsable prints "JOBID" or "JOBID;CLUSTER".
# (--shard-sbatch/--merge-sbatch options come last: on sbatch's command line the last of two
# same options wins, so they may override ours.)
array=$(sbatch --parsable --export=ALL --array="0-$((shards - 1))" --cpus-per-task="$cpus" \
  --output="$PARTS/shard-%A_%a.log" "${shard_sbatch[@]}" "$HERE/shard.sbatch" "${flags[@]}") || {
  echo "render.sh: submitting the shard array failed (sbatch's message is above)" >&2
  exit 1
}
array=${array%%;*}
kill_dep=(--kill-on-invalid-dep=yes)
[ "${RAYLAB_SLURM_KILL_INVALID_DEP:-yes}" = no ] && kill_dep=()
merge=$(sbatch --parsable --export=ALL --dependency="afterok:$array" "${kill_dep[@]}" \
  --output="$PARTS/merge-%j.log" "${merge_sbatch[@]}" "$HERE/merge.sbatch") || {
  echo "render.sh: submitting the merge job failed: cancelling the shards ($array)" >&2
  scancel "$array" || true
  exit 1
}
merge=${merge%%;*}
echo "shards: job array $array (tasks 0-$((shards - 1)), $cpus cpu(s) each), logs $PARTS/shard-${array}_*.log"
echo "merge:  job $merge (after all shards succeed) -> $OUT, log $PARTS/merge-$merge.log"
[ "$wait" = 1 ] || exit 0

# ---- wait --------------------------------------------------------------------------------
# There may be no accounting (no slurmdbd, so no sacct): states come from the controller
# (squeue -t all / scontrol show job), which keeps a finished job for MinJobAge seconds (300
# by default), far longer than one poll.

# "STATE REASON" of job $1, "GONE" once the controller has forgotten it; fails if squeue
# does (controller busy or restarting: the caller asks again). Listing our jobs rather than
# `squeue -j ID` tells the two apart: -j fails for an unknown id too.
me=$(id -un)
job_state() {
  local all
  all=$(squeue -h -t all -u "$me" -o '%i %T %r' 2>/dev/null) || return 1
  awk -v id="$1" '$1 == id { print $2, $3; found = 1; exit } END { if (!found) print "GONE" }' <<<"$all"
}

# Field $2 (e.g. ExitCode) of job $1 from scontrol.
job_field() { scontrol show job -o "$1" 2>/dev/null | head -n 1 | tr ' ' '\n' | sed -n "s/^$2=//p"; }

# Print the array's tasks that did not complete: "TASK STATE exit CODE log FILE".
failed_tasks() {
  scontrol show job -o "$array" 2>/dev/null | while read -r line; do
    local task state code
    task=$(tr ' ' '\n' <<<"$line" | sed -n 's/^ArrayTaskId=//p')
    state=$(tr ' ' '\n' <<<"$line" | sed -n 's/^JobState=//p')
    code=$(tr ' ' '\n' <<<"$line" | sed -n 's/^ExitCode=//p')
    case "$state" in
      COMPLETED | PENDING | RUNNING | CONFIGURING | COMPLETING | REQUEUED | SUSPENDED) ;;
      *) echo "  task $task: $state (exit code $code) log $PARTS/shard-${array}_$task.log" ;;
    esac
  done
}

# Counts of the array's tasks by state, e.g. "2 COMPLETED, 2 RUNNING".
progress() {
  squeue -h -r -t all -j "$array" -o %T 2>/dev/null | sort | uniq -c \
    | awk '{ printf "%s%d %s", (NR > 1 ? ", " : ""), $1, $2 }' || true
}

show_merge_log() {
  local log="$PARTS/merge-$merge.log"
  if [ -e "$log" ]; then
    echo "----- $log -----"
    cat "$log"
    echo "-----"
  fi
}

last="" answered=$SECONDS
while :; do
  if ! now=$(job_state "$merge"); then
    if [ $((SECONDS - answered)) -ge "${RAYLAB_SLURM_GIVE_UP:-300}" ]; then
      echo "render.sh: the Slurm controller has not answered for $((SECONDS - answered))s: giving up (jobs $array and $merge may still run)" >&2
      exit 1
    fi
    sleep "$POLL"
    continue
  fi
  answered=$SECONDS
  read -r state reason <<<"$now"
  case "$state" in
    COMPLETED)
      show_merge_log
      [ -e "$OUT" ] || { echo "render.sh: the merge job completed but $OUT is not there" >&2; exit 1; }
      echo "render.sh: done: $OUT"
      exit 0
      ;;
    PENDING | CANCELLED)
      # A shard failed, so afterok can never be met: the merge never runs. (A failed shard
      # requeued by hand does not revive it in Slurm 22.05: the dependency stays failed. A
      # shard requeued because its node died never failed: the merge just waits for it.)
      if [ "${reason:-}" = DependencyNeverSatisfied ]; then
        echo "render.sh: a shard failed, so the merge job $merge can never run; failed tasks of job array $array:" >&2
        failed_tasks >&2
        [ "$state" = PENDING ] && scancel "$merge" && echo "render.sh: cancelled the merge job $merge" >&2
        echo "render.sh: once the cause is fixed, run the same render.sh command again: shards with a checkpoint resume from it" >&2
        exit 1
      fi
      if [ "$state" = CANCELLED ]; then
        echo "render.sh: the merge job $merge was cancelled (${reason:-})" >&2
        show_merge_log >&2
        exit 1
      fi
      ;;
    FAILED | TIMEOUT | OUT_OF_MEMORY | NODE_FAIL | BOOT_FAIL | DEADLINE | PREEMPTED)
      show_merge_log >&2
      code=$(job_field "$merge" ExitCode) # "EXIT:SIGNAL"
      echo "render.sh: the merge job $merge ended $state (exit code $code)" >&2
      status=${code%%:*} signal=${code##*:}
      if [ "${signal:-0}" != 0 ]; then exit $((128 + signal)); fi
      if [ "${status:-0}" != 0 ]; then exit "$status"; fi
      exit 1
      ;;
    GONE)
      # The controller no longer knows the merge job (purged, or restarted without state).
      if [ -e "$OUT" ]; then
        echo "render.sh: the merge job $merge is gone from the queue; $OUT exists"
        show_merge_log
        exit 0
      fi
      echo "render.sh: the merge job $merge is gone from the queue and $OUT does not exist" >&2
      show_merge_log >&2
      exit 1
      ;;
  esac
  now="merge $state${reason:+ ($reason)}; shards: $(progress)"
  [ "$now" = "$last" ] || echo "render.sh: $now"
  last=$now
  sleep "$POLL"
done

#!/usr/bin/env bash
# Tests the Slurm scripts beside this file on a real multi-node cluster (local-cluster.sh), with a
# stand-in for raylab that takes the same arguments (render writes its argv into the -o file and
# sleeps 1 s; merge concatenates the parts), so no build is needed. Runs as root; starts the
# cluster if it is not running and stops it again at the end in that case.
#
#   scripts/slurm/selftest.sh        # closes with "N passed, N failed"; exit 1 on a failure
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
tmp=$(mktemp -d /tmp/raylab-slurm-test.XXXXXX)
# shellcheck source=testlib.sh
. "$HERE/testlib.sh"
now_ns() { date +%s%N; }

# ---- the cluster -------------------------------------------------------------------------
# (`status`, not sinfo, to tell: sinfo takes seconds to give up on a controller that is down.)
started=0
if ! "$HERE/local-cluster.sh" status >/dev/null 2>&1; then started=1; fi
"$HERE/local-cluster.sh" start
cleanup() {
  if [ "$started" = 1 ]; then "$HERE/local-cluster.sh" stop || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT
# The partition's cpus over all nodes ("allocated/idle/other/total"), and the nodes.
cpus=$(sinfo -h -o %C | head -n 1 | cut -d/ -f4)
mapfile -t nodes < <(sinfo -h -N -o %N | sort -uV)

# ---- a stand-in for raylab ---------------------------------------------------------------
cat >"$tmp/raylab" <<'EOF'
#!/usr/bin/env bash
# render SCENE --shard I/N -o OUT ...: argv into OUT, sleep 1 s (exit 3 if I is in STUB_FAIL)
# merge -o OUT PARTS...: concatenate the parts into OUT (exit STUB_MERGE_EXIT if set)
# Appends "start|end|fail NAME EPOCH-NS" to $STUB_TIMELINE.
set -euo pipefail
cmd=$1; shift
# render ... --check: raylab's checks only; STUB_REFUSE makes them refuse, as raylab would.
if [ "$cmd" = render ] && [[ " $* " == *" --check "* ]]; then
  if [ -n "${STUB_REFUSE:-}" ]; then echo "error: $STUB_REFUSE" >&2; exit 2; fi
  if [ -n "${STUB_REFUSE_RESUME:-}" ] && [[ " $* " == *" --resume "* ]]; then
    echo "error: $STUB_REFUSE_RESUME" >&2
    exit 2
  fi
  exit 0
fi
args=("$@") out="" shard=""
while [ $# -gt 0 ]; do
  case "$1" in -o) out=$2; shift 2 ;; --shard) shard=$2; shift 2 ;; *) shift ;; esac
done
tl() { echo "$1 $2 $(date +%s%N)" >>"$STUB_TIMELINE"; }
case "$cmd" in
  render)
    task=${shard%/*}
    tl start "render-$task"
    sleep 1
    if [[ " ${STUB_FAIL:-} " == *" $task "* ]]; then tl fail "render-$task"; exit 3; fi
    echo "render ${args[*]}" >"$out"
    tl end "render-$task" ;;
  merge)
    tl start merge
    cat "${args[@]:2}" >"$out"
    tl end merge
    if [ -n "${STUB_MERGE_EXIT:-}" ]; then exit "$STUB_MERGE_EXIT"; fi ;;
esac
EOF
chmod +x "$tmp/raylab"
echo scene >"$tmp/scene.ron"
export RAYLAB="$tmp/raylab" RAYLAB_SLURM_POLL=0.5

# run NAME [render.sh args...]: render.sh --wait in $tmp/NAME (its output in NAME/log, exit code
# in $rc, seconds in $secs); a 4-shard render of scene.ron into NAME/out.exr unless args say.
run() {
  local name=$1 t0
  shift
  mkdir -p "$tmp/$name"
  t0=$(now_ns)
  rc=0
  (cd "$tmp/$name" && STUB_TIMELINE="$tmp/$name/timeline" timeout 300 \
    "$HERE/render.sh" "$@" >log 2>&1) || rc=$?
  secs=$(awk -v d=$(($(now_ns) - t0)) 'BEGIN { printf "%.2f", d / 1e9 }')
  touch "$tmp/$name/timeline"
  echo "     render.sh $* -> exit $rc in ${secs}s"
}
# Most renders running at once, per the timeline of $1.
max_overlap() {
  sort -k3,3n "$1" | awk '$1 == "start" && $2 ~ /^render/ { n++; if (n > m) m = n }
    ($1 == "end" || $1 == "fail") && $2 ~ /^render/ { n-- } END { print m + 0 }'
}
# Did the merge start after every render ended?
merge_after_renders() {
  awk '$2 ~ /^render/ && ($1 == "end" || $1 == "fail") && $3 > last { last = $3 }
    $1 == "start" && $2 == "merge" { m = $3 } END { exit !(m > 0 && m >= last) }' "$1"
}

# ---- 1. four shards, all succeed ---------------------------------------------------------
run ok --wait ../scene.ron 4 out.exr --spp 16
check "4 shards + merge: --wait exits 0" [ "$rc" = 0 ]
check "merged image holds the 4 parts in shard order" \
  diff <(sed 's/.*--shard \([0-9]*\)\/4.*/\1/' "$tmp/ok/out.exr") <(printf '%s\n' 0 1 2 3)
check "shard flags: --threads 1, --checkpoint, extra flags" \
  grep -q -- "--shard 2/4 -o $tmp/ok/out.exr.parts/part-2.exr --threads 1 --checkpoint $tmp/ok/out.exr.parts/part-2.ckpt --spp 16\$" "$tmp/ok/out.exr"
expect=$((cpus < 4 ? cpus : 4))
check "shards ran $expect at a time (got $(max_overlap "$tmp/ok/timeline"))" \
  [ "$(max_overlap "$tmp/ok/timeline")" = "$expect" ]
check "merge started after every shard ended" merge_after_renders "$tmp/ok/timeline"
check "--wait printed the merge log" grep -q "merging 4 parts" "$tmp/ok/log"
# The nodes the jobs' logs name ("shard I/N on node X (host X, ..."; "merging ... on node X").
shard_nodes() {
  { cat "$1"/shard-*.log 2>/dev/null || true; } \
    | sed -n 's/^shard [0-9]*\/[0-9]* on node \([^ ]*\) .*/\1/p' | sort -uV | xargs
}
merge_node() {
  { cat "$1"/merge-*.log 2>/dev/null || true; } | sed -n 's/^merging .* on node \([^ ]*\) .*/\1/p' | xargs
}
if [ "${#nodes[@]}" -ge 2 ]; then
  check "the 4 shards spread over the nodes (ran on: $(shard_nodes "$tmp/ok/out.exr.parts"))" \
    [ "$(shard_nodes "$tmp/ok/out.exr.parts" | wc -w)" -ge 2 ]
  # --shard-sbatch/--merge-sbatch: the shards kept off the last node, the merge put on it.
  last=${nodes[-1]}
  run pinned --wait --shard-sbatch --exclude="$last" --merge-sbatch=--nodelist="$last" \
    ../scene.ron 4 out.exr
  check "--shard-sbatch/--merge-sbatch: --wait exits 0" [ "$rc" = 0 ]
  not_on() { [ -n "$1" ] && [[ " $1 " != *" $2 "* ]]; } # not_on NODES NODE
  pinned=$(shard_nodes "$tmp/pinned/out.exr.parts")
  check "--shard-sbatch --exclude=$last: no shard on $last (ran on: $pinned)" not_on "$pinned" "$last"
  check "--merge-sbatch=--nodelist=$last: the merge ran on $last (log: $(merge_node "$tmp/pinned/out.exr.parts"))" \
    [ "$(merge_node "$tmp/pinned/out.exr.parts")" = "$last" ]
else
  no "the cluster has 2 or more nodes (it has ${#nodes[@]})"
fi

# ---- 2. shard 2 fails: the merge never runs, --wait does not hang ------------------------
STUB_FAIL=2 run fail --wait ../scene.ron 4 out.exr
check "failed shard: --wait exits 1 (got $rc after ${secs}s)" [ "$rc" = 1 ]
check "failed shard: task 2 is named" grep -q "task 2: FAILED" "$tmp/fail/log"
check "failed shard: no other task is named" [ "$(grep -c 'task [0-9]*:' "$tmp/fail/log")" = 1 ]
check "failed shard: the merge never started" bash -c "! grep -q merge '$tmp/fail/timeline'"
merge_id=$(sed -n 's/^merge: *job \([0-9]*\).*/\1/p' "$tmp/fail/log")
check "failed shard: the merge job is gone from the queue (cancelled)" \
  bash -c "squeue -h -t all -j '$merge_id' -o '%T %r' | grep -qx 'CANCELLED DependencyNeverSatisfied'"

# The same with the merge left pending (no --kill-on-invalid-dep): render.sh cancels it.
RAYLAB_SLURM_KILL_INVALID_DEP=no STUB_FAIL=0 run pending --wait ../scene.ron 4 out.exr
check "failed shard, merge pending: --wait exits 1 and cancels it" \
  bash -c "[ $rc = 1 ] && grep -q 'task 0: FAILED' '$tmp/pending/log' && grep -q 'cancelled the merge job' '$tmp/pending/log'"

# ---- 3. the merge fails: --wait exits with its status ------------------------------------
STUB_MERGE_EXIT=7 run merge7 --wait ../scene.ron 2 out.exr
check "failed merge: --wait exits with the merge's status 7 (got $rc)" [ "$rc" = 7 ]

# ---- 4. resume: a shard whose checkpoint exists gets --resume, the others do not --------
mkdir -p "$tmp/resume/parts" && touch "$tmp/resume/parts/part-1.ckpt"
run resume --wait --parts parts --cpus 2 ../scene.ron 2 out.exr
check "resume: exits 0" [ "$rc" = 0 ]
check "resume: shard 1 got --resume, shard 0 not; --threads 2" bash -c \
  "grep -q -- '--shard 1/2 .*--threads 2 .*part-1.ckpt --resume' '$tmp/resume/out.exr' && ! grep -q -- '--shard 0/2 .*--resume' '$tmp/resume/out.exr'"
check "resume: logs in --parts" bash -c "ls '$tmp/resume/parts'/shard-*_1.log '$tmp/resume/parts'/merge-*.log >/dev/null"

# ---- 5. bad arguments: exit 2 without submitting -----------------------------------------
bad_args() {
  local rc=0
  (cd "$tmp" && "$HERE/render.sh" "$@" >/dev/null 2>&1) || rc=$?
  [ "$rc" = 2 ]
}
check "bad args: missing scene -> 2" bad_args nosuch.ron 4 o.exr
check "bad args: N=0 -> 2" bad_args scene.ron 0 o.exr
check "bad args: N=x -> 2" bad_args scene.ron x o.exr
check "bad args: --cpus 0 -> 2" bad_args --cpus 0 scene.ron 4 o.exr
check "bad args: too few -> 2" bad_args scene.ron 4
no_raylab() { RAYLAB=no-such-raylab bad_args "$@"; }
check "bad args: RAYLAB not found -> 2" no_raylab scene.ron 4 o.exr
check "bad args: --merge-sbatch without an option -> 2" bad_args --merge-sbatch
check "bad args: --shard-sbatch '' -> 2" bad_args --shard-sbatch '' scene.ron 4 o.exr

# ---- 6. what every task would refuse: exit 2, nothing queued -----------------------------
jobs_now() { squeue -h -u "$(id -un)" -t all -o %i | sort -u | wc -l; }
refused() { # refused DESCRIPTION render.sh-args...: exit 2, and no new job in the queue
  local what=$1 before after
  shift
  before=$(jobs_now)
  if bad_args "$@"; then
    after=$(jobs_now)
    if [ "$after" = "$before" ]; then ok "refused: $what"; else no "refused: $what (queued jobs)"; fi
  else
    no "refused: $what (not exit 2)"
  fi
}
refuse_in_raylab() { STUB_REFUSE="shards take whole blocks of 8 passes" refused "$@"; }
refuse_in_raylab "a render raylab's --check refuses (shard 0)" scene.ron 4 o.exr --spp 16
refused "OUT that merge cannot write (o.jpg)" scene.ron 2 o.jpg
refused "OUT without an extension" scene.ron 2 o
refused "OUT one of the parts" --parts p scene.ron 2 p/part-1.exr
refused "N beyond raylab's limit (100001)" scene.ron 100001 o.exr
refused "N that bash arithmetic would wrap (2^64 + 1)" scene.ron 18446744073709551617 o.exr
refused "a parts folder that cannot be made" --parts /proc/raylab-nope scene.ron 2 o.exr
folder_raylab() { RAYLAB="$tmp" refused "$@"; }
folder_raylab "RAYLAB a folder" scene.ron 2 o.exr
# A checkpoint of another render in the parts folder: its shard's --check refuses to resume it.
mkdir -p "$tmp/stale" && touch "$tmp/stale/part-1.ckpt"
stale_ckpt() { STUB_REFUSE_RESUME="cannot resume: the scene or the render settings changed" refused "$@"; }
stale_ckpt "a stale checkpoint of shard 1" --parts stale scene.ron 2 o.exr

# ---- 7. the parts folder's stamp ---------------------------------------------------------
stamp="$tmp/ok/out.exr.parts/render.stamp"
check "stamp: the first render stamped its parts folder" \
  bash -c "grep -qx 'shards 4' '$stamp' && grep -qx 'flags --spp 16' '$stamp'"
run ok --wait ../scene.ron 4 out.exr --spp 16
check "stamp: the same render submitted again is taken (exit $rc)" [ "$rc" = 0 ]
refused "a parts folder stamped by another render (another N)" \
  --parts ok/out.exr.parts scene.ron 2 ok/out.exr --spp 16
refused "a parts folder stamped by another render (other flags)" \
  --parts ok/out.exr.parts scene.ron 4 ok/out.exr --spp 32
named() {
  local said
  said=$(cd "$tmp" && "$HERE/render.sh" "$@" 2>&1 >/dev/null || true)
  grep -q "belongs to another render" <<<"$said"
}
check "stamp: the refusal says the folder belongs to another render" \
  named --parts ok/out.exr.parts scene.ron 2 ok/out.exr
echo edited >>"$tmp/scene.ron"
refused "a parts folder stamped by the scene before an edit" \
  --parts ok/out.exr.parts scene.ron 4 ok/out.exr --spp 16

echo "$passed passed, $failed failed"
[ "$failed" = 0 ]

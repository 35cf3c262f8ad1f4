#!/usr/bin/env bash
# Tests sharded renders on the local multi-node Slurm cluster (local-cluster.sh) with the real
# raylab binary:
#
#   a. three integrators, each rendered as 3 shards through render.sh --wait, merge into the
#      single run's bytes; the shards run on 2 or more nodes, the merge on a node where no
#      shard ran (render.sh --shard-sbatch --exclude=LAST --merge-sbatch --nodelist=LAST);
#   b. a node dies mid-shard (every process in its namespace killed -9, the node set down):
#      Slurm requeues the task on another node, it resumes from its checkpoint, and the merged
#      image is still the single run's bytes; the node is brought back afterwards;
#   c. a part corrupted on disk (bytes flipped, or cut short) is refused by `raylab merge`
#      with exit 2 and a message naming the part;
#   d. a full disk (a small tmpfs) while writing a part: raylab fails saying the disk is full
#      and leaves no part and no temporary file; through Slurm, render.sh --wait names the
#      failed task.
#
#   RAYLAB=target/debug/raylab scripts/slurm/cluster-test.sh
#
# Runs as root, on a cluster of 3 or more nodes; starts the cluster if it is not running and
# stops it again at the end in that case. Prints "ok   ..." or "FAIL ..." per check and closes
# with "N passed, N failed"; exits 1 on a failure (2 on bad usage).
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
[ -n "${RAYLAB:-}" ] || { echo "usage: RAYLAB=/path/to/raylab $0" >&2; exit 2; }
RAYLAB=$(realpath -- "$RAYLAB")
[ -f "$RAYLAB" ] && [ -x "$RAYLAB" ] || { echo "cluster-test: RAYLAB '$RAYLAB' is not an executable file" >&2; exit 2; }
[ "$(id -u)" = 0 ] || { echo "cluster-test: run it as root (the cluster, the node crash, the tmpfs)" >&2; exit 2; }
export RAYLAB RAYLAB_SLURM_POLL=0.5
SCENE=$ROOT/scenes/cornell_box.ron
tmp=$(mktemp -d /tmp/raylab-cluster-test.XXXXXX)
t_all=$SECONDS
# shellcheck source=testlib.sh
. "$HERE/testlib.sh"
finish() {
  echo "     cluster-test.sh took $((SECONDS - t_all)) s"
  echo "$passed passed, $failed failed"
  [ "$failed" = 0 ]
}

# ---- the cluster -------------------------------------------------------------------------
started=0 full="" crashed=""
if ! "$HERE/local-cluster.sh" status >/dev/null 2>&1; then started=1; fi
cleanup() {
  if [ -n "$full" ] && mountpoint -q "$full"; then umount "$full" || true; fi
  if [ "$started" = 1 ]; then
    "$HERE/local-cluster.sh" stop || true
  elif [ -n "$crashed" ]; then
    "$HERE/local-cluster.sh" start >/dev/null || true # the crashed node back
  fi
  rm -rf "$tmp"
}
trap cleanup EXIT
"$HERE/local-cluster.sh" start
mapfile -t nodes < <(sinfo -h -N -o %N | sort -uV)
if [ "${#nodes[@]}" -lt 3 ]; then
  no "the cluster has 3 or more nodes (it has ${#nodes[@]}: RAYLAB_SLURM_NODES=3 local-cluster.sh start)"
  finish
  exit 1
fi
# The merge goes to the last node, the shards to the others.
merge_node=${nodes[-1]}
echo "     nodes: ${nodes[*]}; shards on all but $merge_node, merges on $merge_node"

# render NAME N [raylab flags...]: render.sh --wait SCENE N NAME/out.exr in the background,
# output in NAME/log; its pid in $bg.
render() {
  local name=$1 n=$2
  shift 2
  mkdir -p "$tmp/$name"
  (cd "$tmp/$name" && exec timeout 300 "$HERE/render.sh" --wait \
    --shard-sbatch="--exclude=$merge_node" --merge-sbatch="--nodelist=$merge_node" \
    "$SCENE" "$n" out.exr "$@" >log 2>&1) &
  bg=$!
}
# finished NAME: wait for the background render.sh; its exit code in $rc, seconds in $secs.
finished() {
  rc=0
  wait "$bg" || rc=$?
  secs=$((SECONDS - t0))
  echo "     $1: render.sh --wait -> exit $rc in ${secs}s"
  [ "$rc" = 0 ] || sed 's/^/     | /' "$tmp/$1/log" | tail -n 20
}
# single NAME [raylab flags...]: the whole render, here, into NAME/single.exr.
single() {
  local name=$1
  shift
  mkdir -p "$tmp/$name"
  "$RAYLAB" render "$SCENE" -q --threads 2 -o "$tmp/$name/single.exr" "$@" 2>"$tmp/$name/single.err" \
    || { sed 's/^/     | /' "$tmp/$name/single.err"; return 1; }
}
# The nodes the logs of NAME name: "shard I/N on node X (host H, ..." and "merging ... on node X".
shard_nodes() {
  { cat "$tmp/$1"/out.exr.parts/shard-*.log 2>/dev/null || true; } \
    | sed -n 's/^shard [0-9]*\/[0-9]* on node \([^ ]*\) .*/\1/p' | sort -uV | xargs
}
merge_nodes() {
  { cat "$tmp/$1"/out.exr.parts/merge-*.log 2>/dev/null || true; } \
    | sed -n 's/^merging .* on node \([^ ]*\) .*/\1/p' | sort -uV | xargs
}
# Did the merge of NAME run on one node, none of whose shards ran there?
merged_elsewhere() {
  local m
  m=$(merge_nodes "$1")
  [ -n "$m" ] && [[ $m != *" "* ]] && [[ " $(shard_nodes "$1") " != *" $m "* ]]
}
count() { wc -w <<<"$1"; }

# ---- a. shards on the nodes merge into the single run's bytes ----------------------------
echo "---- a. three integrators, 3 shards each"
t_a=$SECONDS
declare -A flags=(
  [path]="-i path --size 64x48 --spp 32"
  [bdpt]="-i bdpt --size 64x48 --spp 32"
  [sppm]="-i sppm -p photons=20000 --size 64x48 --spp 32"
)
for i in path bdpt sppm; do
  # shellcheck disable=SC2086
  single "a-$i" ${flags[$i]} || no "a/$i: the single render failed"
  t0=$SECONDS
  # shellcheck disable=SC2086
  render "a-$i" 3 ${flags[$i]}
  finished "a-$i"
  check "a/$i: 3 shards + merge on the cluster: render.sh --wait exits 0" [ "$rc" = 0 ]
  check "a/$i: the merged image is the single run's, byte for byte" \
    cmp -s "$tmp/a-$i/out.exr" "$tmp/a-$i/single.exr"
  sn=$(shard_nodes "a-$i")
  check "a/$i: the shards ran on 2 or more nodes ($sn)" [ "$(count "$sn")" -ge 2 ]
  check "a/$i: the merge ran on $(merge_nodes "a-$i"), where no shard ran" merged_elsewhere "a-$i"
done
# Each node has its own host name: "on node X (host X, ...".
hosts_match() {
  local bad
  bad=$(grep -h " on node " "$tmp"/a-*/out.exr.parts/*.log | grep -v ' on node \([^ ]*\) (host \1,' || true)
  [ -z "$bad" ] || { echo "$bad" | sed 's/^/     | /'; return 1; }
}
check "a: every job's host name is its node's name" hosts_match
echo "     a took $((SECONDS - t_a)) s"

# ---- b. a node dies mid-shard ------------------------------------------------------------
echo "---- b. a node dies mid-shard"
t_b=$SECONDS
kflags=(-i path --size 64x48 --spp 4096) # 2 shards of about 4-8 s each
parts=$tmp/kill/out.exr.parts
t0=$SECONDS
render kill 2 "${kflags[@]}"
# The first shard with a checkpoint, and the node its log names.
victim="" node=""
for _ in $(seq 240); do
  for ck in "$parts"/part-*.ckpt; do
    [ -e "$ck" ] || continue
    victim=${ck##*/part-} victim=${victim%.ckpt}
    node=$({ cat "$parts"/shard-*_"$victim".log 2>/dev/null || true; } \
      | sed -n "s/^shard $victim\/2 on node \([^ ]*\) .*/\1/p" | head -n 1)
    [ -n "$node" ] && break 2
  done
  sleep 0.25
done
if [ -z "$node" ]; then
  no "b: a shard wrote a checkpoint within 60 s"
  finished kill
else
  # Mid-shard: its part is not written yet.
  check "b: shard $victim is mid-render on $node (checkpoint there, no part yet)" [ ! -e "$parts/part-$victim.exr" ]
  crashed=$node
  said=$("$HERE/local-cluster.sh" crash "$node" 2>&1) || no "b: local-cluster.sh crash $node"
  echo "$said" | sed 's/^/     /'
  # What a health check (or the admin) does on a dead node: Slurm then requeues its jobs at
  # once, instead of after SlurmdTimeout (about 50 s here) without an answer.
  scontrol update nodename="$node" state=down reason="cluster-test: crashed" \
    || no "b: scontrol update nodename=$node state=down"
  check "b: nothing of $node runs any more" [ -z "$(ip netns pids "raylab-$node" 2>/dev/null)" ]
  # The single run, while the requeued task waits out its BeginTime (cred_expire, 30 s).
  single kill "${kflags[@]}" || no "b: the single render failed"
  finished kill
  check "b: render.sh --wait exits 0 after the crash" [ "$rc" = 0 ]
  log=$(cat "$parts"/shard-*_"$victim".log 2>/dev/null || true)
  check "b: task $victim was requeued and resumed from its checkpoint (its log says so)" \
    grep -q "^resuming from $parts/part-$victim.ckpt at [0-9]* spp" <<<"$log"
  again=$(sed -n "s/^shard $victim\/2 on node \([^ ]*\) .*/\1/p" <<<"$log" | tail -n 1)
  check "b: the requeued task ran on another node (${again:-none}, not $node)" \
    test -n "$again" -a "$again" != "$node"
  check "b: the merged image is still the single run's, byte for byte" \
    cmp -s "$tmp/kill/out.exr" "$tmp/kill/single.exr"
  check "b: the merge ran on $(merge_nodes kill), where no shard ran" merged_elsewhere kill
  # Bring the node back: its slurmd again; ReturnToService=2 returns it to service.
  "$HERE/local-cluster.sh" start >/dev/null && crashed=""
  check "b: $node is back ($(sinfo -h -n "$node" -o %T))" \
    bash -c "sinfo -h -n '$node' -o %T | grep -qE '^(idle|mixed|allocated)$'"
fi
echo "     b took $((SECONDS - t_b)) s"

# ---- c. a part corrupted on disk ---------------------------------------------------------
echo "---- c. corrupted parts"
c=$tmp/corrupt
mkdir -p "$c"
for i in 0 1 2; do
  # shellcheck disable=SC2086
  "$RAYLAB" render "$SCENE" -q --threads 2 ${flags[path]} --shard "$i/3" -o "$c/part-$i.exr" \
    || no "c: render shard $i/3 here"
done
corrupt_refused() { # corrupt_refused HOW: merge exits 2 naming part-1.exr, writes nothing
  local msg rc=0
  rm -f "$c/merged.exr"
  msg=$("$RAYLAB" merge -q -o "$c/merged.exr" "$c/part-0.exr" "$c/part-1.exr" "$c/part-2.exr" 2>&1) || rc=$?
  echo "     $1: exit $rc: $msg"
  [ "$rc" = 2 ] && grep -qF "$c/part-1.exr" <<<"$msg" && [ ! -e "$c/merged.exr" ]
}
cp "$c/part-1.exr" "$c/good-1.exr" 2>/dev/null || : >"$c/good-1.exr"
size=$(stat -c %s "$c/part-1.exr" 2>/dev/null || echo 0)
printf '\xde\xad\xbe\xef\xde\xad\xbe\xef' | dd of="$c/part-1.exr" bs=1 seek=$((size / 2)) conv=notrunc status=none
check "c: 8 bytes flipped in the middle of part-1.exr: merge exits 2 naming it, writes nothing" \
  corrupt_refused flipped
head -c $((size / 2)) "$c/good-1.exr" >"$c/part-1.exr"
check "c: part-1.exr cut to half: merge exits 2 naming it, writes nothing" corrupt_refused truncated
: >"$c/part-1.exr"
check "c: part-1.exr empty: merge exits 2 naming it, writes nothing" corrupt_refused empty

# ---- d. the disk fills up while a part is written ----------------------------------------
echo "---- d. a full disk"
full=$tmp/full
mkdir -p "$full"
if ! mount -t tmpfs -o size=200k raylab-cluster-test "$full"; then
  no "d: mount a 200 KB tmpfs on $full"
  full=""
else
  dflags=(-i path --size 128x96 --spp 32) # a part of about 600 KB: it does not fit in 200 KB
  rc=0
  msg=$("$RAYLAB" render "$SCENE" -q --threads 2 "${dflags[@]}" --shard 0/2 -o "$full/part-0.exr" 2>&1) || rc=$?
  echo "     exit $rc: $msg"
  check "d: a part that does not fit: raylab fails (exit $rc; not 0, not a panic's 101)" \
    test "$rc" != 0 -a "$rc" != 101
  check "d: its message says the disk is full and names the part" \
    bash -c 'grep -qi "disk is full" <<<"$1" && grep -qF "$2" <<<"$1"' _ "$msg" "$full/part-0.exr"
  left=$(ls -A "$full" | xargs)
  check "d: nothing is left in the folder (no part, no temporary file)${left:+ (left: $left)}" \
    [ -z "$left" ]
  # The same through Slurm: the parts folder on the full tmpfs (the nodes share the root
  # namespace's mounts). Both tasks fail, render.sh --wait names them and exits 1.
  mkdir -p "$tmp/full-slurm"
  (cd "$tmp/full-slurm" && timeout 300 "$HERE/render.sh" --wait --parts "$full/parts" \
    --shard-sbatch="--exclude=$merge_node" "$SCENE" 2 out.exr "${dflags[@]}" >log 2>&1) && rc=0 || rc=$?
  echo "     full-slurm: render.sh --wait -> exit $rc"
  check "d: through Slurm: render.sh --wait exits 1 and names the failed tasks" \
    bash -c "[ $rc = 1 ] && grep -q 'task 0: FAILED' '$tmp/full-slurm/log' && grep -q 'task 1: FAILED' '$tmp/full-slurm/log'"
  grep -hi 'disk is full' "$full"/parts/shard-*.log 2>/dev/null | sed 's/^/     | /' || true
  check "d: through Slurm: the shard logs say the disk is full" \
    bash -c "[ \$(grep -li 'disk is full' '$full'/parts/shard-*.log | wc -l) = 2 ]"
  left=$(ls -A "$full/parts" | grep -vE '^(render\.stamp|shard-[0-9_]+\.log)$' | xargs || true)
  check "d: through Slurm: no part and no temporary file left${left:+ (left: $left)}" [ -z "$left" ]
  umount "$full" && full=""
fi

finish

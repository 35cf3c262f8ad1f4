#!/usr/bin/env bash
# A real multi-node Slurm cluster on this machine, for trying and testing the sharded render
# scripts beside this file (render.sh, shard.sbatch, merge.sbatch).
#
#   local-cluster.sh start        install slurm-wlm + munge if missing, write the config, make
#                                 the nodes' network, start munged, slurmctld and one slurmd per
#                                 node, wait until every node is up. Idempotent: it starts only
#                                 what is missing (a node that crashed, a half-made network).
#   local-cluster.sh stop         cancel every job, stop the daemons this script started, remove
#                                 the nodes' network namespaces, veth pairs and the bridge
#   local-cluster.sh status       print `sinfo -N` (and squeue)
#   local-cluster.sh crash NODE   kill -9 every process of NODE (its slurmd, its jobs and their
#                                 programs) as if the machine had died; `start` brings it back
#
# Each node (node1 .. nodeN) is a network namespace (raylab-nodeI) with its own address on a
# Linux bridge in the root namespace ($NET.0/24; the bridge is $NET.1, where slurmctld
# listens), and its own host name (a UTS namespace): `hostname` in a job says which node it
# runs on. munged (a unix socket) and slurmctld are shared, and so is the file system: jobs see
# the same paths as the login node (the root namespace), so parts travel through the shared
# folder as on a real cluster.
#
# Runs as root (CI, a container, a VM). It starts the daemons directly, not via systemctl, so it
# works without systemd. Debian 12's slurm-wlm is 22.05; its commands read /etc/slurm/slurm.conf,
# so the config is written there. A slurm.conf this script did not write is never overwritten.
#
# Environment:
#   RAYLAB_SLURM_NODES     number of nodes (default: as many as the running cluster has, else 3)
#   RAYLAB_SLURM_NET       the nodes' /24 network, its first three numbers (default 10.77.0)
#   RAYLAB_SLURM_NODE_MEM  RealMemory of each node in MiB (default: the machine's, see below)
#   RAYLAB_SLURM_DIR       state, spool, logs and pid files (default /var/lib/raylab-slurm)
#   RAYLAB_SLURM_TIMEOUT   seconds `start` waits for the nodes to be up (default 60)
set -euo pipefail

BASE=${RAYLAB_SLURM_DIR:-/var/lib/raylab-slurm}
TIMEOUT=${RAYLAB_SLURM_TIMEOUT:-60}
NODES=${RAYLAB_SLURM_NODES:-}
NET=${RAYLAB_SLURM_NET:-10.77.0}
CONF=/etc/slurm/slurm.conf
MARKER="# Written by raylab scripts/slurm/local-cluster.sh"
LOGS=$BASE/log
RUN=$BASE/run
# Names in the root namespace: the bridge, the host ends of the veth pairs (rlv-nodeI) and the
# network namespaces (raylab-nodeI). `stop` removes whatever carries these names.
BRIDGE=rlslurm0
NS_PREFIX=raylab-
VETH_PREFIX=rlv-

die() { echo "local-cluster: $*" >&2; exit 1; }
say() { echo "local-cluster: $*"; }

[[ $NET =~ ^[0-9]{1,3}\.[0-9]{1,3}\.[0-9]{1,3}$ ]] \
  || die "RAYLAB_SLURM_NET must be the first three numbers of an IPv4 /24 (e.g. 10.77.0), not '$NET'"

node_names() { local i; for ((i = 1; i <= NODES; i++)); do echo "node$i"; done; }
node_addr() { echo "$NET.$((10 + ${1#node}))"; } # node1 -> 10.77.0.11
node_ns() { echo "$NS_PREFIX$1"; }
node_veth() { echo "$VETH_PREFIX$1"; }

# Is the daemon whose pid file is $1 running, and is it a $2? (The name is checked too, so a
# stale pid file whose pid was reused by another process does not count.)
alive_pid() {
  local pid
  pid=$(cat "$1" 2>/dev/null) || return 1
  [ -n "$pid" ] && [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$2" ]
}
# Is the daemon named $1 running, per its pid file $RUN/$1.pid?
alive() { alive_pid "$RUN/$1.pid" "$1"; }
# Is node $1's slurmd running, inside the node's network namespace?
node_alive() {
  alive_pid "$RUN/slurmd-$1.pid" slurmd \
    && [ "$(ip netns identify "$(cat "$RUN/slurmd-$1.pid")" 2>/dev/null)" = "$(node_ns "$1")" ]
}

# Print the pids of the slurmd processes this script starts ("/usr/sbin/slurmd -N nodeI") for
# node $1, or for every node without $1, wherever they run: also one left in a namespace that
# is gone, or whose pid file is gone.
our_slurmds() {
  local f cmd pat="^/usr/sbin/slurmd -N ${1:-node[0-9]+}\$"
  for f in /proc/[0-9]*/cmdline; do
    cmd=$(tr '\0' ' ' 2>/dev/null <"$f") || continue
    [[ ${cmd% } =~ $pat ]] && { f=${f#/proc/}; echo "${f%/cmdline}"; }
  done
  return 0
}

# Without RAYLAB_SLURM_NODES, a running cluster keeps its size (so that `start` on it, as the
# tests do, does not restart it with another one).
if [ -z "$NODES" ]; then
  NODES=3
  if alive slurmctld && grep -qxF "$MARKER" "$CONF" 2>/dev/null; then
    NODES=$(grep -c '^NodeName=node' "$CONF" || true)
    [ "$NODES" -ge 1 ] 2>/dev/null || NODES=3 # the one-node cluster of an older version
  fi
fi
[[ $NODES =~ ^[0-9]{1,3}$ ]] && [ "$NODES" -ge 1 ] && [ "$NODES" -le 200 ] \
  || die "RAYLAB_SLURM_NODES must be a number from 1 to 200, not '$NODES'"
NODES=$((10#$NODES))

# Can this machine make and check a munge credential (i.e. is a munged answering)?
munge_ok() { munge -n 2>/dev/null | unmunge >/dev/null 2>&1; }

# Print the tail of every daemon log, for an error message.
show_logs() {
  local f
  for f in "$LOGS"/slurmctld.log "$LOGS"/slurmd-*.log "$LOGS"/munged.log; do
    [ -e "$f" ] || continue
    echo "----- last lines of $f -----" >&2
    tail -n 25 "$f" >&2
  done
}

# Install slurm-wlm and munge (and iproute2 for `ip`) when they are missing (a fresh Debian 12).
install_packages() {
  local need=()
  command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
    && command -v sbatch >/dev/null || need+=(slurm-wlm)
  command -v munged >/dev/null || need+=(munge)
  command -v ip >/dev/null || need+=(iproute2)
  [ ${#need[@]} -gt 0 ] || return 0
  [ "$(id -u)" -eq 0 ] || die "${need[*]} not installed and this is not root"
  say "installing ${need[*]} (apt-get)"
  apt-get update -qq
  # policy-rc.d 101: the packages' post-install must not start daemons (no systemd here, and we
  # start them ourselves with our config); removed again right after.
  local policy=/usr/sbin/policy-rc.d made_policy=0
  if [ ! -e "$policy" ]; then
    printf '#!/bin/sh\nexit 101\n' >"$policy" && chmod 755 "$policy" && made_policy=1
  fi
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    "${need[@]}" >/dev/null || { [ "$made_policy" = 1 ] && rm -f "$policy"; die "apt-get install failed"; }
  [ "$made_policy" = 1 ] && rm -f "$policy"
  return 0
}

# Print the config for $NODES nodes with this machine's cpus and memory.
make_config() {
  local cpus mem found nodes
  cpus=$(nproc)
  mem=$(free -m | awk '/^Mem:/ { print $2 }') # MiB
  # slurmd drains a node whose configured memory is above what it finds itself (reason "Low
  # RealMemory"): never configure more than `slurmd -C` reports (the same figure here).
  found=$(slurmd -C 2>/dev/null | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' | head -n 1)
  if [ -n "$found" ] && [ "$found" -lt "$mem" ]; then mem=$found; fi
  if [ -n "${RAYLAB_SLURM_NODE_MEM:-}" ]; then
    [[ $RAYLAB_SLURM_NODE_MEM =~ ^[0-9]+$ ]] && [ "$RAYLAB_SLURM_NODE_MEM" -le "$mem" ] \
      || die "RAYLAB_SLURM_NODE_MEM must be a number of MiB up to the machine's $mem, not '$RAYLAB_SLURM_NODE_MEM'"
    mem=$RAYLAB_SLURM_NODE_MEM
  fi
  nodes="node[1-$NODES]"
  [ "$NODES" = 1 ] && nodes=node1
  cat <<EOF
$MARKER
# A $NODES-node cluster on one machine for local runs and CI; regenerated by every
# \`local-cluster.sh start\`. Node I is the network namespace ${NS_PREFIX}nodeI at $NET.(10+I);
# slurmctld listens on the bridge $BRIDGE at $NET.1.
ClusterName=raylab
SlurmctldHost=localhost($NET.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
# A requeued job waits cred_expire seconds before it may start again (120 s by default): 30 s
# here, so that a shard requeued from a failed node starts again soon.
AuthInfo=cred_expire=30
MpiDefault=none
# Debian has no /bin/mail by default: slurmctld logs an error for the default MailProg.
MailProg=/bin/true
# No cgroups (containers, no systemd): plain /proc process tracking, no task binding.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
# No slurmdbd: no accounting (so no sacct; job states come from squeue/scontrol).
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
# Cores are the consumable, and each job goes to the least loaded node (CR_LLN): the tasks of
# a job array spread over the nodes instead of filling node1 first.
SelectType=select/cons_tres
SelectTypeParameters=CR_Core,CR_LLN
# A node that was down comes back by itself when its slurmd registers again.
ReturnToService=2
# Short timeouts: one machine, nothing to wait for.
SlurmctldTimeout=30
SlurmdTimeout=30
MessageTimeout=10
InactiveLimit=0
KillWait=5
Waittime=0
# Schedule as soon as a job ends (batch_sched_delay is 3 s by default: with it, each wave of
# an array and the merge after it starts only on slurmctld's next 3-second tick). A requeued
# job that becomes eligible again (its BeginTime) is started by the backfill scheduler, which
# runs every bf_interval seconds (30 by default): every 5 s here.
SchedulerParameters=batch_sched_delay=0,bf_interval=5
# Finished jobs stay visible to squeue/scontrol this long (render.sh --wait reads their states).
MinJobAge=600
StateSaveLocation=$BASE/state
# One spool folder, pid file and log per node (%n: the node's name).
SlurmdSpoolDir=$BASE/spool/%n
SlurmdPidFile=$RUN/slurmd-%n.pid
SlurmdLogFile=$LOGS/slurmd-%n.log
SlurmctldPidFile=$RUN/slurmctld.pid
SlurmctldLogFile=$LOGS/slurmctld.log
SlurmctldDebug=info
SlurmdDebug=info
# Every node declares all of the machine's cpus (they share them: a test cluster), and all of
# its memory: memory is not a consumable here (CR_Core), so RealMemory is only the most one job
# may ask for, and shard.sbatch's --mem=8G must fit a node (a third of 24 GiB does not).
EOF
  local n
  for n in $(node_names); do
    echo "NodeName=$n NodeAddr=$(node_addr "$n") CPUs=$cpus RealMemory=$mem State=UNKNOWN"
  done
  echo "PartitionName=main Nodes=$nodes Default=YES MaxTime=INFINITE State=UP"
}

# Is $CONF ours (or absent)? Dies if another one is there.
check_conf_ours() {
  if [ -e "$CONF" ] && ! grep -qxF "$MARKER" "$CONF"; then
    die "$CONF exists and was not written by this script: not overwriting it (move it away first)"
  fi
}

# Write $1 (a config) to $CONF, unless it holds that already.
write_config() {
  mkdir -p /etc/slurm "$BASE/state" "$BASE/spool" "$LOGS" "$RUN"
  [ "$(cat "$CONF" 2>/dev/null)" = "$1" ] && return 0
  local tmp
  tmp=$(mktemp "$CONF.XXXXXX")
  printf '%s\n' "$1" >"$tmp"
  chmod 644 "$tmp"
  mv -f "$tmp" "$CONF"
  say "wrote $CONF ($NODES nodes: $(grep -m1 -o 'CPUs=[0-9]* RealMemory=[0-9]*' "$CONF")M each)"
}

# ---- the network -------------------------------------------------------------------------
# The bridge in the root namespace, with the controller's address.
bridge_up() {
  local other
  # Another interface with an address in our /24 would take the nodes' traffic.
  other=$(ip -4 -o addr show 2>/dev/null | awk -v net="$NET." -v br="$BRIDGE" \
    '$2 != br && index($4, net) == 1 { print $2 " " $4 }')
  [ -z "$other" ] \
    || die "$NET.0/24 is in use here ($other): set RAYLAB_SLURM_NET to a free /24, e.g. 10.78.0"
  if ! ip link show "$BRIDGE" >/dev/null 2>&1; then
    ip link add "$BRIDGE" type bridge \
      || die "cannot make the bridge $BRIDGE (ip link add type bridge): no bridge support in this kernel?"
  fi
  ip addr replace "$NET.1/24" dev "$BRIDGE"
  ip link set "$BRIDGE" up
}

# Is node $1's network whole: its namespace, its address on eth0, its veth on the bridge?
node_net_ok() {
  local ns veth
  ns=$(node_ns "$1") veth=$(node_veth "$1")
  ip -o link show "$veth" 2>/dev/null | grep -q " master $BRIDGE " || return 1
  ip -o link show "$veth" 2>/dev/null | grep -q "[<,]UP[,>]" || return 1
  ip -n "$ns" -4 -o addr show dev eth0 2>/dev/null | grep -qF " $(node_addr "$1")/24 " || return 1
  ip -n "$ns" -o link show dev eth0 2>/dev/null | grep -q "[<,]UP[,>]"
}

# Kill -9 every process in network namespace $1 (a node's slurmd, slurmstepd and jobs).
kill_ns() {
  local pids
  pids=$(ip netns pids "$1" 2>/dev/null || true)
  # shellcheck disable=SC2086
  [ -z "$pids" ] || kill -9 $pids 2>/dev/null || true
  for _ in $(seq 50); do
    [ -z "$(ip netns pids "$1" 2>/dev/null || true)" ] && return 0
    sleep 0.1
  done
}

# Remove node $1's network (and kill what runs in it).
node_net_down() {
  local ns veth
  ns=$(node_ns "$1") veth=$(node_veth "$1")
  if [ -e "/run/netns/$ns" ]; then
    kill_ns "$ns"
    ip netns del "$ns" 2>/dev/null || true
  fi
  ip link del "$veth" 2>/dev/null || true
}

# Make node $1's network: a namespace with lo and eth0 (its address), the other end of the
# veth pair on the bridge.
node_net_up() {
  local ns veth addr
  ns=$(node_ns "$1") veth=$(node_veth "$1") addr=$(node_addr "$1")
  ip netns add "$ns"
  ip link add "$veth" type veth peer name eth0 netns "$ns"
  ip link set "$veth" master "$BRIDGE" up
  ip -n "$ns" link set lo up
  ip -n "$ns" addr add "$addr/24" dev eth0
  ip -n "$ns" link set eth0 up
  ip -n "$ns" route add default via "$NET.1"
}

net_up() {
  bridge_up
  local n
  for n in $(node_names); do
    node_net_ok "$n" && continue
    node_net_down "$n" # whatever a half-started run left
    node_net_up "$n" || { node_net_down "$n"; die "cannot make the network of $n"; }
  done
}

# Remove every node's network, the bridge, and whatever carries our names (also nodes of a run
# with more nodes than now).
net_down() {
  local ns link
  for ns in $(ip netns list 2>/dev/null | awk '{ print $1 }' | grep "^${NS_PREFIX}node[0-9]*$" || true); do
    kill_ns "$ns"
    ip netns del "$ns" 2>/dev/null || true
  done
  for link in $(ip -o link show 2>/dev/null | awk -F': ' '{ print $2 }' | sed 's/@.*//' \
    | grep "^${VETH_PREFIX}node[0-9]*$" || true); do
    ip link del "$link" 2>/dev/null || true
  done
  ip link del "$BRIDGE" 2>/dev/null || true
}

# ---- the daemons -------------------------------------------------------------------------
# Start munged (as the munge user, like Debian's unit) unless one already answers.
start_munge() {
  if munge_ok; then
    return
  fi
  local key=/etc/munge/munge.key
  if [ ! -s "$key" ]; then
    say "creating $key"
    mkdir -p /etc/munge
    if command -v mungekey >/dev/null; then
      mungekey --create --keyfile="$key"
    else
      dd if=/dev/urandom of="$key" bs=1024 count=1 status=none
    fi
  fi
  # munged refuses a key or directories that others can read or write.
  chown munge:munge /etc/munge "$key"
  chmod 700 /etc/munge
  chmod 400 "$key"
  # /run/munge is normally made by systemd (RuntimeDirectory=munge): make it ourselves.
  mkdir -p /run/munge /var/lib/munge /var/log/munge
  chown munge:munge /run/munge /var/lib/munge /var/log/munge
  chmod 755 /run/munge
  : >"$LOGS/munged.log"
  chown munge:munge "$LOGS/munged.log"
  runuser -u munge -- /usr/sbin/munged --log-file="$LOGS/munged.log" \
    --pid-file=/run/munge/munged.pid
  cp /run/munge/munged.pid "$RUN/munged.pid" # we started it, so `stop` stops it
  for _ in $(seq 50); do
    munge_ok && return
    sleep 0.1
  done
  show_logs
  die "munged does not answer"
}

# Start node $1's slurmd inside its network namespace, in a UTS namespace of its own whose
# host name is the node's name. (nsenter, not `ip netns exec`: that one also mounts a /sys of
# its own, without /sys/fs/cgroup, and slurmd 22.05 does not start without it. So the nodes
# share the root namespace's mounts, a tmpfs mounted later included.)
start_slurmd() {
  mkdir -p "$BASE/spool/$1"
  rm -f "$RUN/slurmd-$1.pid"
  # A slurmd of this node left outside its namespace (its namespace was removed under it).
  local stray
  stray=$(our_slurmds "$1" | xargs)
  # shellcheck disable=SC2086
  [ -z "$stray" ] || { say "killing a stray slurmd of $1 (pid $stray)"; kill -9 $stray 2>/dev/null || true; }
  nsenter --net="/run/netns/$(node_ns "$1")" -- unshare --uts -- /bin/sh -c \
    'echo "$1" >/proc/sys/kernel/hostname && exec /usr/sbin/slurmd -N "$1"' sh "$1" \
    || { show_logs; die "slurmd of $1 did not start"; }
}

# Start slurmctld and every node's slurmd unless they run already.
start_slurm() {
  if ! alive slurmctld; then
    # -c: a cold start (no jobs or node states kept from a previous run); it daemonizes.
    /usr/sbin/slurmctld -c || { show_logs; die "slurmctld did not start"; }
  fi
  local n
  for n in $(node_names); do
    node_alive "$n" || start_slurmd "$n"
  done
}

# Print "NODE STATE" for every node, or nothing if the controller does not answer.
node_states() { sinfo -h -N -o '%N %T' 2>/dev/null | sort -u; }

wait_up() {
  local deadline=$((SECONDS + TIMEOUT)) states="" polls=0 n up
  while [ "$SECONDS" -lt "$deadline" ]; do
    # A daemon that exited (a port in use, a bad config) will not come back: say so now. (From
    # the 5th poll on: a daemon that has just forked may not have written its pid file yet.)
    polls=$((polls + 1))
    if [ "$polls" -ge 5 ]; then
      alive slurmctld || { show_logs; die "slurmctld exited (its log is above; is another Slurm running here, port 6817?)"; }
      for n in $(node_names); do
        node_alive "$n" || { show_logs; die "the slurmd of $n exited (its log is above)"; }
      done
    fi
    states=$(node_states)
    up=0
    for n in $(node_names); do
      case "$(awk -v n="$n" '$1 == n { print $2 }' <<<"$states")" in
        idle | mixed | allocated | completing) up=$((up + 1)) ;; # up (jobs may run already)
        # A node left drained or down by an earlier run: ask for it back.
        drain* | down*) scontrol update nodename="$n" state=resume >/dev/null 2>&1 || true ;;
      esac
    done
    [ "$up" = "$NODES" ] && return 0
    sleep 0.5
  done
  show_logs
  sinfo -N -l >&2 2>/dev/null || true
  [ -n "$states" ] || states="no answer from slurmctld"
  die "not every node is up after ${TIMEOUT}s (states: ${states//$'\n'/, })"
}

# Is everything of a $NODES-node cluster running, on this config?
all_running() {
  alive slurmctld || return 1
  [ "$(cat "$CONF" 2>/dev/null)" = "$1" ] || return 1
  local n
  for n in $(node_names); do node_alive "$n" && node_net_ok "$n" || return 1; done
}

cmd_start() {
  [ "$(id -u)" -eq 0 ] || die "start needs root (the daemons and the network namespaces)"
  local t0 conf
  t0=$(date +%s%N)
  install_packages
  check_conf_ours
  conf=$(make_config)
  if all_running "$conf"; then
    say "already running"
  else
    if { [ -e "$CONF" ] && [ "$(cat "$CONF")" != "$conf" ]; } || alive slurmd; then
      # Another node list (or the one-node cluster of an older version of this script): what
      # runs on the old config goes, jobs included, and so do the old nodes' namespaces.
      if alive slurmctld || alive slurmd || compgen -G "$RUN/slurmd-*.pid" >/dev/null; then
        say "the config changed: restarting the cluster"
      fi
      cmd_stop >/dev/null
    fi
    write_config "$conf"
    net_up
    start_munge
    start_slurm
  fi
  wait_up
  local ms=$((($(date +%s%N) - t0) / 1000000))
  say "up: $(node_states | awk '{ printf "%s%s %s", (NR > 1 ? ", " : ""), $1, $2 }') (start took $((ms / 1000)).$(printf %03d $((ms % 1000)))s)"
}

# Is any of the pids in the arguments alive?
any_alive() {
  local pid
  for pid in "$@"; do kill -0 "$pid" 2>/dev/null && return 0; done
  return 1
}

# Stop the daemons whose "PIDFILE:NAME" are in the arguments (TERM to all at once, KILL
# after 10 s), and remove their pid files.
stop_daemons() {
  local spec pids=() pid
  for spec in "$@"; do
    if alive_pid "${spec%:*}" "${spec##*:}"; then pids+=("$(cat "${spec%:*}")"); fi
  done
  if [ ${#pids[@]} -gt 0 ]; then
    kill "${pids[@]}" 2>/dev/null || true
    for _ in $(seq 100); do
      any_alive "${pids[@]}" || break
      sleep 0.1 # slurmd takes some 3 s to shut down
    done
    for pid in "${pids[@]}"; do
      if kill -0 "$pid" 2>/dev/null; then
        say "pid $pid ($(cat "/proc/$pid/comm" 2>/dev/null)) did not stop: killing it"
        kill -9 "$pid" 2>/dev/null || true
      fi
    done
  fi
  for spec in "$@"; do rm -f "${spec%:*}"; done
}

cmd_stop() {
  if alive slurmctld; then
    # Cancel every job first, so slurmd ends their processes, and wait (briefly) for them.
    local jobs
    jobs=$(squeue -h -o %A 2>/dev/null | sort -u || true)
    if [ -n "$jobs" ]; then
      say "cancelling jobs: ${jobs//$'\n'/ }"
      # shellcheck disable=SC2086
      scancel $jobs 2>/dev/null || true
      for _ in $(seq 50); do
        [ -z "$(squeue -h -t running,completing -o %A 2>/dev/null)" ] && break
        sleep 0.2
      done
    fi
  fi
  # Every slurmd with a pid file (also of nodes beyond $NODES, and the one-node cluster's
  # slurmd.pid of older versions of this script), and slurmctld.
  local specs=("$RUN/slurmctld.pid:slurmctld" "$RUN/slurmd.pid:slurmd") f
  for f in "$RUN"/slurmd-*.pid; do
    [ -e "$f" ] && specs+=("$f:slurmd")
  done
  stop_daemons "${specs[@]}"
  # What is left in the nodes' namespaces (a job's processes) goes with them, and so does a
  # slurmd of ours that lost its pid file or its namespace.
  net_down
  local stray
  stray=$(our_slurmds | xargs)
  # shellcheck disable=SC2086
  [ -z "$stray" ] || { say "killing stray slurmd processes (pids $stray)"; kill -9 $stray 2>/dev/null || true; }
  # munged only if this script started it (a system munged is left alone).
  stop_daemons "$RUN/munged.pid:munged"
  say "stopped"
}

cmd_status() {
  if ! alive slurmctld; then
    echo "local-cluster: slurmctld is not running (start it with: $0 start)"
    return 1
  fi
  sinfo -N
  squeue
}

# Kill -9 every process of node $1, as if it had died.
cmd_crash() {
  [ "$(id -u)" -eq 0 ] || die "crash needs root"
  local n=${1:-} ns
  [[ $n =~ ^node[0-9]+$ ]] || die "usage: $0 crash NODE (node1 .. node$NODES)"
  ns=$(node_ns "$n")
  [ -e "/run/netns/$ns" ] || die "$n has no network namespace $ns: is the cluster up?"
  local pids
  pids=$(ip netns pids "$ns" | tr '\n' ' ')
  kill_ns "$ns"
  rm -f "$RUN/slurmd-$n.pid"
  say "crashed $n (killed pids ${pids% }); \`$0 start\` starts its slurmd again"
}

case "${1:-}" in
  start) cmd_start ;;
  stop) cmd_stop ;;
  status) cmd_status ;;
  crash) cmd_crash "${2:-}" ;;
  *)
    echo "usage: $0 start|stop|status|crash NODE" >&2
    exit 2
    ;;
esac

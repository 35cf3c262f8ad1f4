# The tallies of the Slurm test scripts (selftest.sh, cluster-test.sh), sourced by them: each
# check prints "ok   ..." or "FAIL ...", and the script closes with "N passed, N failed".
passed=0 failed=0

ok() { echo "ok   $*"; passed=$((passed + 1)); }
no() { echo "FAIL $*"; failed=$((failed + 1)); }
check() { # check DESCRIPTION COMMAND...: pass if the command succeeds
  local what=$1
  shift
  if "$@"; then ok "$what"; else no "$what"; fi
}

# tests/lib.sh: helpers shared by the shell tests, sourced after `set -euo pipefail`:
#   . "$DTX_SRC/tests/lib.sh"
#
#   check DESCRIPTION COMMAND...   run COMMAND; print "ok: DESCRIPTION" or
#                                  "FAILED: DESCRIPTION" and count the failure
#   finish                         print the summary line; fails (status 1)
#                                  when any check failed: end the test with it
fails=0
check() { # check DESCRIPTION COMMAND...
    local what=$1; shift
    if "$@"; then echo "ok: $what"; else echo "FAILED: $what"; fails=$((fails + 1)); fi
}
finish() {
    echo "$((fails == 0 ? 1 : 0)) passed, $fails failed"
    [ "$fails" -eq 0 ]
}

# census ROW OUTCOME: with DTX_CENSUS=FILE set, one line "ROW OUTCOME" per
# bad input tried (scripts/bad-input-census.sh tallies them); OUTCOME is one
# of clear-error, accepted, false-success, crash, hang, unclear-message,
# leftovers, accept-failed.
census() { [ -z "${DTX_CENSUS:-}" ] || echo "$1 $2" >> "$DTX_CENSUS"; }

# bounded COMMAND...: COMMAND under a 120 s timeout (exit 124 when it hangs),
# unless it is a shell function or already a timeout.
bounded() {
    if [ "$1" != timeout ] && [ "$(type -t "$1")" = file ]; then timeout 120 "$@"; else "$@"; fi
}

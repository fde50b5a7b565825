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

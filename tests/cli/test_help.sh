#!/usr/bin/env bash
# The command line explains itself: `dtx help` lists every command; `dtx help
# CMD` and `dtx CMD --help` (exit 0) print its usage, every option with a line
# on what it does, and examples; every option literal a command's source
# parses appears in that command's help (so no option is undocumented); an
# unknown option or a missing value is a usage error (exit 2) that prints
# the command's own usage, not every command's; `dtx --version`.
set -uo pipefail
. "$DTX_SRC/tests/lib.sh"
W="$DTX_TESTDATA"
cd "$W" || exit 1

check "dtx help exits 0" "$DTX" help
"$DTX" help > overview.txt 2>&1
check "dtx --help prints the same overview" cmp -s overview.txt <("$DTX" --help 2>&1)
# The command names: the lines under "commands:" (one or two words, then the summary).
mapfile -t cmds < <(sed -n '/^commands:/,/^$/p' overview.txt | sed -n 's/^  \([a-z]*\( [a-z]*\)\?\)  .*/\1/p' |
                    sed 's/ *$//')
check "the overview lists the commands (${#cmds[@]})" test "${#cmds[@]}" -ge 14
for c in "${cmds[@]}"; do
    # shellcheck disable=SC2086
    out=$("$DTX" $c --help 2>&1); rc=$?
    check "dtx $c --help exits 0" test "$rc" -eq 0
    check "dtx $c --help has usage, options and examples" \
        grep -q "^dtx $c: " <<<"$out"
    for part in "^usage:" "^options:" "^  -h, --help"; do
        check "dtx $c --help: $part" grep -q -- "$part" <<<"$out"
    done
    # shellcheck disable=SC2086
    check "dtx help $c prints the same" test "$out" = "$("$DTX" help $c 2>&1)"
    # shellcheck disable=SC2086
    check "dtx $c -h prints the same" test "$out" = "$("$DTX" $c -h 2>&1)"
    printf '%s\n' "$out" > "help-${c// /-}.txt"
done

# Every option literal of a command's source is in its help.  cmd_X.c holds
# command X, cmd_import.c the three import commands; cli_util.c knows which
# options of import and run take a value (and diff's --tol, from when diff
# was parsed in main.c).
opts_of() { grep -ohE '"(--[a-z0-9][a-z0-9-]*|-o)"' "$@" | tr -d '"' | sort -u |
            grep -vxE -- '--help|--version'; }
for src in "$DTX_SRC"/src/cli/cmd_*.c "$DTX_SRC"/src/cli/cli_util.c "$DTX_SRC"/src/cli/main.c; do
    base=$(basename "$src" .c)
    if [ "$base" = main ]; then
        helps="overview.txt"  # no options of its own
    elif [ "$base" = cli_util ]; then
        helps="help-import-mesh.txt help-import-sequence.txt help-import-markers.txt help-run.txt
               help-diff.txt"
    elif [ "$base" = cmd_import ]; then
        helps="help-import-mesh.txt help-import-sequence.txt help-import-markers.txt"
    elif [ "$base" = cmd_uvsplit ]; then
        helps="help-generate.txt"  # dtx generate uvsplit
    else
        helps="help-${base#cmd_}.txt"
    fi
    # shellcheck disable=SC2086
    if ! ls $helps > /dev/null 2>&1; then
        check "$base.c belongs to a command with a help" false
        continue
    fi
    while read -r o; do
        [ -n "$o" ] || continue
        # shellcheck disable=SC2086
        check "$base.c's option $o is in its help" grep -qE -- "^  (.*, )?$o( |$)" $helps
    done < <(opts_of "$src")
done

# Usage errors: exit 2, the command's own usage only, and no file touched.
out=$("$DTX" diff a.h5 b.h5 /results/x --tolerance 1 2>&1); rc=$?
check "an unknown option is a usage error (exit 2)" test "$rc" -eq 2
check "... naming the command and the option" grep -q "dtx: diff: unknown option --tolerance" <<<"$out"
check "... with the command's own usage" grep -q "dtx diff A.h5 B.h5" <<<"$out"
check "... and not every command's" test "$(grep -c "dtx export" <<<"$out")" -eq 0
out=$("$DTX" export f.h5 /results/x --pc2 2>&1); rc=$?
check "a missing value is a usage error (exit 2)" test "$rc" -eq 2
check "... saying which option" grep -q -- "--pc2 needs a value" <<<"$out"
out=$("$DTX" import mesh 2>&1); rc=$?
check "dtx import mesh without arguments: exit 2" test "$rc" -eq 2
check "... with the import mesh usage only" \
    test "$(grep -c "dtx import mesh" <<<"$out")" -ge 1 -a "$(grep -cE "dtx import (sequence|markers)" <<<"$out")" -eq 0
out=$("$DTX" frobnicate 2>&1); rc=$?
check "an unknown command: exit 2 and the overview" test "$rc" -eq 2 -a -n "$(grep '^commands:' <<<"$out")"
out=$("$DTX" help frobnicate 2>&1); rc=$?
check "help on an unknown command: exit 2" test "$rc" -eq 2
out=$("$DTX" diff a.h5 b.h5 /results/x --tol --help 2>&1); rc=$?
check "an option's value '--help' is a value, not a request for help" \
    test "$rc" -ne 0 -a -z "$(grep '^options:' <<<"$out")"
check "dtx --version" grep -qE '^dtx [0-9]+\.[0-9]+\.[0-9]+$' <<<"$("$DTX" --version)"
check "dtx version" test "$("$DTX" version)" = "$("$DTX" --version)"
check "no file was written" test -z "$(ls | grep -v '^help-\|^overview.txt$')"
finish

#!/usr/bin/env bash
# bad-input-census.sh: the bad-input table's figures, measured.
#
# Usage: scripts/bad-input-census.sh
#   Builds build/ (as scripts/build.sh), runs the bad-input tests
#   (cli.bad_input, cli.bad_input_table, cli.checks, cli.import_layouts) with
#   DTX_CENSUS set, so
#   each bad input they try is recorded with its outcome, and prints one row
#   per class of input (the part of the row tag before its first '-'):
#   tried, clear error (non-zero exit, the message the table promises, no
#   output left), accepted as documented (exit 0 with the promised warning),
#   crash (exit > 2 or a signal), hang (no answer in 120 s), false success
#   (exit 0 where an error was due), leftovers (OUTPUT, .partial or .lock
#   left), unclear (another message than the table's). Exit status 0 when
#   the last four columns are all 0.
# Environment: DTX_SKIP_SETUP=1 skips scripts/setup.sh.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$repo"
DTX_SKIP_SETUP=${DTX_SKIP_SETUP:-0} scripts/build.sh > /dev/null
census=$(mktemp "${TMPDIR:-/tmp}/dtx-census.XXXXXX")
trap 'rm -f "$census"' EXIT
DTX_CENSUS=$census ctest --test-dir build -R '^cli\.(bad_input|bad_input_table|checks|import_layouts)$' \
    -j2 > /dev/null || echo "census: warning: some bad-input test failed (see ctest)" >&2
python3 - "$census" <<'PY'
import collections, sys
cols = ["clear-error", "accepted", "crash", "hang", "false-success", "leftovers",
        "unclear-message", "accept-failed"]
heads = ["tried", "clear error", "accepted", "crash", "hang", "false success", "leftovers",
         "unclear", "accept failed"]
rows = collections.defaultdict(collections.Counter)
for line in open(sys.argv[1]):
    tag, outcome = line.split()
    cls = tag.split(":")[0] if ":" in tag else tag.split("-")[0]
    rows[cls][outcome] += 1
print("| class | " + " | ".join(heads) + " |")
print("|---" * (len(heads) + 1) + "|")
total = collections.Counter()
for cls in sorted(rows):
    c = rows[cls]
    total.update(c)
    print("| %s | %d | %s |" % (cls, sum(c.values()), " | ".join(str(c[k]) for k in cols)))
print("| **all** | %d | %s |" % (sum(total.values()), " | ".join(str(total[k]) for k in cols)))
bad = sum(total[k] for k in cols[2:])
sys.exit(1 if bad else 0)
PY

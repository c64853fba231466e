#!/bin/sh
# Regenerates the flag tables of docs/cli.md from the command line itself
# (`rayline --cli-reference`): the hand-written part above the marker line is kept, the rest
# is replaced. With --check, changes nothing and exits 1 with a diff when docs/cli.md is
# stale (the ctest `cli.reference` runs that).
#   scripts/update_cli_reference.sh [--check] [RAYLINE_BINARY]   (default build/apps/rayline)
set -eu
ROOT=$(cd "$(dirname "$0")/.." && pwd)
CHECK=0
if [ "${1:-}" = "--check" ]; then CHECK=1; shift; fi
BIN=${1:-$ROOT/build/apps/rayline}
DOC=$ROOT/docs/cli.md
MARKER='<!-- Generated from the command line below this line by scripts/update_cli_reference.sh: do not edit. -->'

grep -qxF "$MARKER" "$DOC" || { echo "update_cli_reference.sh: $DOC: the marker line is missing: $MARKER" >&2; exit 2; }
NEW=$(mktemp "${TMPDIR:-/tmp}/cli.md.XXXXXX")
trap 'rm -f "$NEW"' EXIT
# The hand-written part, up to and including the marker, then the generated tables.
sed "/^$(printf '%s' "$MARKER" | sed 's/[][\\/.*^$]/\\&/g')\$/q" "$DOC" > "$NEW"
"$BIN" --cli-reference >> "$NEW"

if [ "$CHECK" = 1 ]; then
  if ! diff -u "$DOC" "$NEW"; then
    echo "docs/cli.md is stale: run scripts/update_cli_reference.sh and commit the result" >&2
    exit 1
  fi
  exit 0
fi
if cmp -s "$DOC" "$NEW"; then echo "docs/cli.md is up to date"; exit 0; fi
cp "$NEW" "$DOC.tmp" && mv "$DOC.tmp" "$DOC"
echo "rewrote docs/cli.md"

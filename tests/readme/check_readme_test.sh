#!/usr/bin/env bash
# readme.detects_failures: scripts/check_readme.sh on sample.md, a README whose third
# command fails. Checks the commands extracted (comments removed, continuations joined,
# other languages left out), the pass/fail/skip report and the exit status.
set -uo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
check="$here/../../scripts/check_readme.sh"
status=0
fail() { echo "check_readme_test: $*" >&2; status=1; }

listed="$("$check" --list "$here/sample.md")"
expected="printf '%s\n' one  two > joined.txt
test \"\$(tr '\n' ' ' < joined.txt)\" = \"one two \" && echo 'a # in quotes' | grep -q '#'
true && false && touch never
cmake --version"
[ "$listed" = "$expected" ] || fail "extracted commands differ:"$'\n'"$listed"$'\n'"expected:"$'\n'"$expected"

report="$("$check" --quick "$here/sample.md")"; rc=$?
echo "$report"
[ "$rc" = 1 ] || fail "exit status $rc, expected 1"
grep -q "^PASS .*printf '%s\\\\n' one  two > joined.txt$" <<<"$report" || fail "the joined command did not pass"
grep -q "^PASS .*test " <<<"$report" || fail "the && command did not pass"
grep -q "^FAIL .*true && false && touch never$" <<<"$report" || fail "the failing command was not reported"
grep -q "(false: exit 1)" <<<"$report" || fail "the failing part was not named"
grep -q "^SKIP .*cmake --version$" <<<"$report" || fail "--quick did not skip cmake"
grep -q "4 commands: 2 passed, 1 failed, 1 skipped" <<<"$report" || fail "wrong summary"
exit $status

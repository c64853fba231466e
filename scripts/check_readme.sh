#!/usr/bin/env bash
# Runs every command of README.md's ```sh blocks and reports pass or fail for each; exits 1
# when any fails. Usage:
#   scripts/check_readme.sh [--quick] [--build DIR] [--timeout SECONDS] [--list] [--keep] [FILE.md]
#
# Commands: a line of a ```sh block, with its continuation lines (ending in \) joined and its
# comments (# to the end of the line, outside quotes) removed; comment-only lines are none.
# `A && B` is run part by part, in order, until one fails.
#
# Where they run: in a scratch folder that links every entry of the repository (build/ to
# --build, default build/), except out/, so that outputs land in the scratch folder's out/,
# which is removed at the end (--keep keeps it). The commands that act on the build itself
# (`cmake ...`, `scripts/setup.sh ...`) run in the repository root: setup.sh is idempotent
# and, with every package installed, the assets fetched and the build up to date, takes
# about 20 s. Each part has --timeout seconds (default 600).
#
# Markers: --quick (the ctest readme.quick, tests/README.md) skips, and says so, the parts
# that match QUICK_SKIP below: those that rebuild or rerun the build under test, and the
# renders and calibration (a minute together). Without --quick nothing is skipped.
set -uo pipefail

# QUICK_SKIP: "extended regular expression ## reason", matched against each part of a command.
QUICK_SKIP=(
  '^scripts/setup\.sh ## installs, fetches and builds: the build under test is already there'
  '^cmake( |$) ## configures or builds the build under test'
  '^ctest( |$) ## runs tests of the suite that runs this check'
  'rayline (render|calibrate)( |$) ## renders and calibration: a minute together on 2 cores'
  'rayline simulate --like ## the twin of a render the quick check skips'
)

# The distributed commands as README's user runs them: Open MPI refuses root unless told.
[ "$(id -u)" -eq 0 ] && export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BUILD="$ROOT/build"
TIMEOUT=600
QUICK=0; LIST=0; KEEP=0
README="$ROOT/README.md"
while (($#)); do
  case "$1" in
    --quick) QUICK=1 ;;
    --list) LIST=1 ;;
    --keep) KEEP=1 ;;
    --build) BUILD="$(cd "$2" && pwd)" || exit 2; shift ;;
    --timeout) TIMEOUT="$2"; shift ;;
    -h|--help) sed -n 2,20p "$0"; exit 0 ;;
    -*) echo "check_readme: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) README="$1" ;;
  esac
  shift
done
[ -f "$README" ] || { echo "check_readme: $README: no such file" >&2; exit 2; }

# strip_comment LINE: LINE without its comment (an unquoted # at the start or after a blank).
strip_comment() {
  local s="$1" out="" q="" c prev=" " i
  for ((i = 0; i < ${#s}; i++)); do
    c="${s:i:1}"
    if [ -n "$q" ]; then
      [ "$c" = "$q" ] && q=""
    elif [ "$c" = "'" ] || [ "$c" = '"' ]; then
      q="$c"
    elif [ "$c" = "#" ] && [[ "$prev" == [[:space:]] ]]; then
      break
    fi
    out+="$c"; prev="$c"
  done
  out="${out%"${out##*[![:space:]]}"}"  # trailing blanks
  printf '%s' "${out#"${out%%[![:space:]]*}"}"  # leading blanks
}

# split_and CMD: the parts of CMD between unquoted &&, one per line.
split_and() {
  local s="$1" part="" q="" c i
  for ((i = 0; i < ${#s}; i++)); do
    c="${s:i:1}"
    if [ -z "$q" ] && [ "${s:i:2}" = "&&" ]; then
      printf '%s\n' "$(strip_comment "$part")"; part=""; ((i++)); continue
    fi
    if [ -n "$q" ]; then [ "$c" = "$q" ] && q=""
    elif [ "$c" = "'" ] || [ "$c" = '"' ]; then q="$c"; fi
    part+="$c"
  done
  printf '%s\n' "$(strip_comment "$part")"
}

# The commands of every ```sh block, one per line.
extract_commands() {
  local in_block=0 line cmd="" s
  while IFS= read -r line || [ -n "$line" ]; do
    if ((!in_block)); then
      [[ "$line" =~ ^\`\`\`sh[[:space:]]*$ ]] && in_block=1
      continue
    fi
    if [[ "$line" =~ ^\`\`\` ]]; then in_block=0; cmd=""; continue; fi
    s="$(strip_comment "$line")"
    if [[ "$s" == *\\ ]]; then cmd+="${s%\\} "; continue; fi
    cmd+="$s"
    [ -n "$cmd" ] && printf '%s\n' "$cmd"
    cmd=""
  done <"$README"
}

# quick_skip PART: the reason PART is skipped under --quick (empty: it runs).
quick_skip() {
  local entry
  ((QUICK)) || return 0
  for entry in "${QUICK_SKIP[@]}"; do
    if [[ "$1" =~ ${entry%% ## *} ]]; then printf '%s' "${entry#* ## }"; return 0; fi
  done
}

mapfile -t COMMANDS < <(extract_commands)
if ((LIST)); then printf '%s\n' "${COMMANDS[@]}"; exit 0; fi
((${#COMMANDS[@]})) || { echo "check_readme: no commands in $README" >&2; exit 1; }

SCRATCH="$(mktemp -d "${TMPDIR:-/tmp}/rayline-readme.XXXXXX")"
cleanup() { if ((KEEP)); then echo "check_readme: outputs kept in $SCRATCH"; else rm -rf "$SCRATCH"; fi; }
trap cleanup EXIT
for entry in "$ROOT"/* "$ROOT"/.[!.]*; do
  name="$(basename "$entry")"
  case "$name" in out|build|.git) continue ;; esac
  [ -e "$entry" ] && ln -s "$entry" "$SCRATCH/$name"
done
ln -s "$BUILD" "$SCRATCH/build"
mkdir -p "$SCRATCH/.logs"

pass=0; fail=0; skip=0; n=0; start_all=$SECONDS
for cmd in "${COMMANDS[@]}"; do
  ((n++))
  mapfile -t parts < <(split_and "$cmd")
  status=PASS; detail=""; t0=$SECONDS
  for part in "${parts[@]}"; do
    reason="$(quick_skip "$part")"
    if [ -n "$reason" ]; then status=SKIP; detail="$reason"; ((${#parts[@]} > 1)) && detail="$part: $reason"; break; fi
    dir="$SCRATCH"
    [[ "$part" =~ ^(cmake|scripts/setup\.sh)( |$) ]] && dir="$ROOT"
    log="$SCRATCH/.logs/$n.log"
    (cd "$dir" && timeout --kill-after=10 "$TIMEOUT" bash -c "$part") >>"$log" 2>&1 </dev/null
    rc=$?
    if ((rc != 0)); then
      status=FAIL
      detail="exit $rc$( ((rc == 124)) && echo ", over ${TIMEOUT} s")"
      ((${#parts[@]} > 1)) && detail="$part: $detail"
      break
    fi
  done
  case "$status" in
    PASS) ((pass++)); printf 'PASS %4ds  %s\n' $((SECONDS - t0)) "$cmd" ;;
    SKIP) ((skip++)); printf 'SKIP        %s\n            (%s)\n' "$cmd" "$detail" ;;
    FAIL) ((fail++)); printf 'FAIL %4ds  %s\n            (%s)\n' $((SECONDS - t0)) "$cmd" "$detail"
          tail -n 15 "$log" | sed 's/^/            | /' ;;
  esac
done
echo "check_readme: ${#COMMANDS[@]} commands: $pass passed, $fail failed, $skip skipped, $((SECONDS - start_all)) s"
((fail == 0))

#!/bin/sh
# Runs every experiment of the notebooks and refreshes the notebooks and their figures.
#
#   scripts/experiments/run_all.sh --full      # all experiments (about 80 min on 2 cores, 40 of them
#                                              # notebook 09's real renders):
#                                              # CSVs in notebooks/results/, notebooks executed in
#                                              # place, PNG figures next to them
#   scripts/experiments/run_all.sh --reduced   # the CI setting (short runs, few points) into
#                                              # out/notebooks-reduced/; committed files untouched
#
# Needs a built `rayline` (build/apps/rayline, or set RAYLINE_BIN) and Debian's
# /usr/bin/python3 with pandas, matplotlib, nbconvert, ipykernel (scripts/setup.sh installs them).
set -eu
cd "$(dirname "$0")/../.."
mode=${1:---full}
export MPLBACKEND=Agg PYDEVD_DISABLE_FILE_VALIDATION=1
case "$mode" in
  --full)
    /usr/bin/python3 scripts/experiments/experiments.py all --mode full --out notebooks/results
    /usr/bin/python3 notebooks/make_notebooks.py
    for nb in notebooks/[0-9][0-9]_*.ipynb; do
      /usr/bin/python3 -m nbconvert --to notebook --execute --inplace --ExecutePreprocessor.timeout=1200 "$nb"
    done
    ;;
  --reduced)
    out=out/notebooks-reduced
    mkdir -p "$out"
    for nb in notebooks/[0-9][0-9]_*.ipynb; do
      RAYLINE_NB_REDUCED=1 RAYLINE_NB_OUT="$PWD/$out/$(basename "$nb" .ipynb)" \
        /usr/bin/python3 -m nbconvert --to notebook --execute "$nb" --output-dir "$out" --ExecutePreprocessor.timeout=600
    done
    ;;
  *) echo "usage: $0 --full | --reduced" >&2; exit 2 ;;
esac

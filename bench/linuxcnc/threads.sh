#!/usr/bin/env bash
# G33 thread starts in LinuxCNC's simulator, for comparison with our G33
# (issue 7): runs the four thread examples of docs/dialects.md §2.3.5
# (programs/thread_ex*.ngc) at 200, 800 and (where the spindle allows it)
# 2000 rpm with run.sh, then
# prints a markdown table made by thread_stats.py (definitions:
# `thread_stats.py --explain`).
#
#   bench/linuxcnc/threads.sh [--analyse-only]
#
#   --analyse-only   do not run LinuxCNC, analyse the TSVs already in $OUT
#
# TSVs and the manifest go to $OUT (default ${TMPDIR:-/tmp}/linuxcnc-threads).
# Limits are run.sh's defaults (config/lathe.toml, config/mill.toml); the
# same environment overrides apply (Z_MAX_ACC, Y_MAX_ACC, SPINDLE_MAX_RPM...).
# Needs root or a user allowed to run linuxcnc; about 3 minutes.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
P="$HERE/programs"
OUT="${OUT:-${TMPDIR:-/tmp}/linuxcnc-threads}"
PY=/usr/bin/python3
RUN=1
case "${1:-}" in
    --analyse-only) RUN=0 ;;
    "") ;;
    *) sed -n '2,16p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2 ;;
esac
mkdir -p "$OUT"

LATHE_MAX_RPM="${SPINDLE_MAX_RPM:-4000}"    # run.sh/lathe.ini.in default
MILL_MAX_RPM="${SPINDLE_MAX_RPM:-12000}"    # run.sh/mill.ini.in default
LATHE_ACC="${Z_MAX_ACC:-2500}"              # lead axis Z on the lathe
MILL_ACC="${Y_MAX_ACC:-2000}"               # lead axis Y on the mill
rpms() {  # speeds that the spindle allows: 200 800 2000
    local max="$1" r
    for r in 200 800 2000; do
        awk -v r="$r" -v m="$max" 'BEGIN{exit !(r <= m)}' && printf '%s ' "$r"
    done
    return 0
}

MANIFEST="$OUT/manifest.tsv"
: > "$MANIFEST"
T0=$(date +%s)
# one() GROUP LABEL PROGRAM MACHINE LEAD PITCH SPEC_START ACC MODE RPM...
one() {
    local group="$1" label="$2" prog="$3" machine="$4" lead="$5" pitch="$6"
    local start="$7" acc="$8" mode="$9" rpm tsv
    shift 9
    for rpm in "$@"; do
        tsv="$OUT/$(basename "$prog" .ngc)_s$rpm.tsv"
        if [ "$RUN" = 1 ]; then
            echo "threads.sh: $(basename "$prog") at $rpm rpm ($machine)" >&2
            if [ "$machine" = lathe ]; then
                "$HERE/run.sh" "$P/$prog" "$tsv" --lathe --rpm "$rpm" 2>"$OUT/run.log" \
                    || { cat "$OUT/run.log" >&2; exit 1; }
            else
                "$HERE/run.sh" "$P/$prog" "$tsv" --rpm "$rpm" 2>"$OUT/run.log" \
                    || { cat "$OUT/run.log" >&2; exit 1; }
            fi
        fi
        printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$group" "$label" \
            "$P/$prog" "$tsv" "$rpm" "$lead" "$pitch" "$start" "$acc" "$mode" >> "$MANIFEST"
    done
}

LR="$(rpms "$LATHE_MAX_RPM")"
MR="$(rpms "$MILL_MAX_RPM")"
# shellcheck disable=SC2086
{
one ex1 "1 lathe Z-40 K1" thread_ex1_lathe.ngc lathe z 1 5 "$LATHE_ACC" full $LR
one ex2 "2 mill Y-30 K1.5 (I180: start Y5.75)" thread_ex2_mill_y.ngc mill y 1.5 5 "$MILL_ACC" full $MR
one ex3 "3 lathe taper X12 Z-40, 2/rev on Z" thread_ex3_lathe_taper.ngc lathe z 2 5 "$LATHE_ACC" full $LR
one ex4 "4 lathe Z-43 K1 (runout not cut)" thread_ex4_lathe_runout.ngc lathe z 1 5 "$LATHE_ACC" full $LR
one ex3k "3 with literal K2 (lead/rev only)" thread_ex3_lathe_taper_k2.ngc lathe z 2 5 "$LATHE_ACC" pitch 800
}
[ "$RUN" = 1 ] && echo "threads.sh: runs took $(( $(date +%s) - T0 )) s; TSVs in $OUT" >&2
"$PY" "$HERE/thread_stats.py" "$MANIFEST"

#!/usr/bin/env bash
# Jerk-limited motion at realistic jerk (issue 17): ours at several jerk
# limits beside LinuxCNC 2.9 (which has no jerk limit), on the CAM-like
# program `gen.py cam` with "G64 P0.01", every axis at 100 mm/s and
# 1000 mm/s²; the table adds the curvature bound (analyse.py
# curvature_bound) and the ratio to LinuxCNC's cycle time.
#
#   bash bench/motion/jerk.sh [--jerks "20 50 100 200 1000"] [--ours-only]
#                             [--analyse-only] [--out DIR] [--mode "G64 P0.01"]
#                             [--method filters|path|auto] [--program cam|part|dense]
#
#   --jerks LIST    jerk limits, m/s³, one run of ours each (default 20 50 100 200 1000; 200 the bundled machines')
#   --ours-only     do not run LinuxCNC; reuse lcnc_PROGRAM.tsv in the output directory
#   --analyse-only  run nothing, re-analyse the output directory
#   --out DIR       default bench/out/jerk
#   --program P     the gen.py program, cam (default), part or dense
#   --method M      our planner ([planner] method; default "filters", as every
#                   figure before the default became "auto")
#
# The machine files: config/mill.toml with max_velocity_mm_s = 100,
# max_acceleration_mm_s2 = 1000 and max_jerk_mm_s3 = J·1000 on every axis
# (written to DIR/mill_jJ.toml). LinuxCNC gets the same velocity and
# acceleration through bench/linuxcnc/run.sh's X_MAX_VEL etc.
# Environment: CNC (default: cargo build --release, target/release/cnc),
# CNC_LABEL, BENCH_TIMEOUT. LinuxCNC needs root (bench/linuxcnc/).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
say() { printf 'jerk: %s\n' "$*" >&2; }
usage() { sed -n '2,25p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
JERKS="20 50 100 200 1000" OURS_ONLY=0 ANALYSE_ONLY=0 OUT="$ROOT/bench/out/jerk" MODE="G64 P0.01" METHOD="filters" PROG=cam
VEL=100 ACC=1000
while [ $# -gt 0 ]; do
    case "$1" in
        --jerks) JERKS="${2:?}"; shift ;;
        --ours-only) OURS_ONLY=1 ;;
        --analyse-only) ANALYSE_ONLY=1 ;;
        --out) OUT="${2:?}"; shift ;;
        --mode) MODE="${2:?}"; shift ;;
        --method) METHOD="${2:?}"; shift ;;
        --program) PROG="${2:?}"; shift ;;
        -h|--help) usage ;;
        *) say "unknown argument $1"; usage ;;
    esac
    shift
done
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
PY="${PYTHON:-python3}"
export LC_ALL=C
T0=$(date +%s)
MAN="$OUT/manifest.tsv"
machine() {  # machine J FILE: config/mill.toml at VEL/ACC and jerk J m/s³
    sed -e "s/^max_velocity_mm_s = .*/max_velocity_mm_s = $VEL.0/" \
        -e "s/^max_acceleration_mm_s2 = .*/max_acceleration_mm_s2 = $ACC.0/" \
        -e "s/^max_jerk_mm_s3 = .*/max_jerk_mm_s3 = $1000.0/" \
        -e "s|^program_dir = .*|program_dir = \"$OUT\"|" \
        "$ROOT/config/mill.toml" > "$2"
    if [ -n "$METHOD" ]; then
        sed -i "s/^lookahead_blocks = \(.*\)/lookahead_blocks = \1\nmethod = \"$METHOD\"/" "$2"
    fi
}
if [ $ANALYSE_ONLY = 0 ]; then
    "$PY" "$HERE/gen.py" "$PROG" --dialect cnc836 --mode "$MODE" -o "$OUT/$PROG.nc"
    "$PY" "$HERE/gen.py" "$PROG" --dialect linuxcnc --mode "$MODE" -o "$OUT/$PROG.ngc"
    if [ -z "${CNC:-}" ]; then
        (cd "$ROOT" && cargo build --release --locked -p cnc_node --bin cnc >&2)
        CNC="$ROOT/target/release/cnc"
        rev="$(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo '?')"
        git -C "$ROOT" diff --quiet HEAD -- cnc_core cnc_node sim_axes 2>/dev/null || rev="$rev+uncommitted"
        CNC_LABEL="${CNC_LABEL:-ours $rev}"
    fi
    CNC_LABEL="${CNC_LABEL:-ours ($CNC)}"
    : > "$OUT/ours.manifest"
    for j in $JERKS; do
        m="$OUT/mill_j$j.toml"
        machine "$j" "$m"
        "$CNC" check "$OUT/$PROG.nc" --machine "$m" | tee "$OUT/check_j$j.txt" >&2
        "$CNC" simulate "$OUT/$PROG.nc" --machine "$m" --csv "$OUT/ours_${PROG}_j$j.csv" >&2
        printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$PROG" "$CNC_LABEL" "$MODE" "$OUT/$PROG.nc" "$OUT/ours_${PROG}_j$j.csv" "$m" >> "$OUT/ours.manifest"
    done
    if [ $OURS_ONLY = 0 ]; then
        machine 1000000 "$OUT/mill_lcnc.toml"   # its velocity and acceleration (no jerk in 2.9)
        LCNC_VER="$(dpkg-query -W -f '${Version}' linuxcnc-uspace 2>/dev/null || echo 2.9)"
        echo "LinuxCNC ${LCNC_VER%%+*}" > "$OUT/linuxcnc.label"
        ok=0
        for try in 1 2; do
            say "LinuxCNC (try $try)"
            if X_MAX_VEL=$VEL Y_MAX_VEL=$VEL Z_MAX_VEL=$VEL X_MAX_ACC=$ACC Y_MAX_ACC=$ACC Z_MAX_ACC=$ACC \
                BENCH_TIMEOUT="${BENCH_TIMEOUT:-300}" bash "$ROOT/bench/linuxcnc/run.sh" "$OUT/$PROG.ngc" "$OUT/lcnc_$PROG.tsv" 2> "$OUT/lcnc_$PROG.log"; then
                ok=1; break
            fi
            tail -5 "$OUT/lcnc_$PROG.log" >&2
        done
        [ $ok = 1 ] || { say "LinuxCNC failed twice; see $OUT/lcnc_$PROG.log"; exit 1; }
        printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$PROG" "$(cat "$OUT/linuxcnc.label")" "$MODE" "$OUT/$PROG.ngc" "$OUT/lcnc_$PROG.tsv" "$OUT/mill_lcnc.toml" > "$OUT/linuxcnc.manifest"
    fi
fi
cat "$OUT/linuxcnc.manifest" "$OUT/ours.manifest" > "$MAN"
"$PY" "$HERE/analyse.py" --jerk-table "$MAN" --json "$OUT/results.json" > "$OUT/table.md"
echo
cat "$OUT/table.md"
say "done in $(( $(date +%s) - T0 )) s; outputs in $OUT"

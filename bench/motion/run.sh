#!/usr/bin/env bash
# Motion quality side by side with LinuxCNC 2.9 (issue 9): the same programs
# and limits through `cnc simulate` and LinuxCNC's headless simulator, and
# one table (cycle time, stops, path deviation, acceleration and velocity
# per axis) computed from the 1 ms samples and the program geometry.
#
#   bash bench/motion/run.sh [--tolerance MM] [--ours-only] [--no-g61]
#                            [--analyse-only] [--out DIR]
#
#   --tolerance MM  also run ours with "G64 P<MM>" as the line after the
#                   header (skipped, with a note, if `cnc check` refuses it)
#   --ours-only     do not run LinuxCNC; use its TSVs from an earlier run in
#                   the output directory where they exist
#   --no-g61        leave out the LinuxCNC G61 runs (4 of the 8.5 minutes)
#   --analyse-only  run nothing, re-analyse what is in the output directory
#   --out DIR       output directory (default bench/out/motion)
#
# Programs (bench/motion/gen.py, written in both dialects from one source):
#   part          3-axis test part, 432 moves
#   dense         10,000 lines of 0.01-0.5 mm at F3000, 1 um noise
#   dense_smooth  the same without the noise (LinuxCNC without G61)
# LinuxCNC variants: G64 P0.01, G64 P0.01 Q0 (dense: naive-CAM merging off),
# G61 (dense_smooth: no G61). Ours: as the program is (no G64 line), and
# with --tolerance.
#
# Environment: CNC=path/to/cnc (default: cargo build --release, then
# target/release/cnc), CNC_LABEL (name in the table), BENCH_TIMEOUT (s per
# LinuxCNC run, default 300). LinuxCNC needs root (see bench/linuxcnc/).
# Limits: config/mill.toml for ours, the same numbers in
# bench/linuxcnc/mill.ini.in; do not set X_MAX_ACC etc. here.
# Takes about 8.5 minutes (LinuxCNC runs in real time), 4.5 without G61.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
say() { printf 'motion: %s\n' "$*" >&2; }
usage() { sed -n '2,30p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }

TOL="" OURS_ONLY=0 G61=1 ANALYSE_ONLY=0 OUT="$ROOT/bench/out/motion"
while [ $# -gt 0 ]; do
    case "$1" in
        --tolerance) TOL="${2:?--tolerance needs a value}"; shift ;;
        --tolerance=*) TOL="${1#--tolerance=}" ;;
        --ours-only) OURS_ONLY=1 ;;
        --no-g61) G61=0 ;;
        --analyse-only) ANALYSE_ONLY=1 ;;
        --out) OUT="${2:?}"; shift ;;
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

# ---- programs ----------------------------------------------------------------
PROGS="part dense dense_smooth"
gen() {  # gen PROGRAM DIALECT MODE OUTFILE
    local extra=""
    case "$1" in dense_smooth) extra="--noise 0"; set -- dense "${@:2}" ;; esac
    "$PY" "$HERE/gen.py" "$1" --dialect "$2" --mode "$3" -o "$4" $extra
}
lmode_name() { echo "$1" | tr 'A-Z ' 'a-z_' | tr -d '.'; }   # "G64 P0.01" -> g64_p001
lcnc_modes() {
    case "$1" in
        part) echo "G64 P0.01"; [ $G61 = 1 ] && echo "G61" ;;
        dense) echo "G64 P0.01"; echo "G64 P0.01 Q0"; [ $G61 = 1 ] && echo "G61" ;;
        dense_smooth) echo "G64 P0.01"; echo "G64 P0.01 Q0" ;;
    esac
    return 0
}

MANIFEST="$OUT/manifest.tsv"
NOTES="$OUT/notes.txt"
if [ $ANALYSE_ONLY = 0 ]; then
    : > "$NOTES"
    # ---- ours ----------------------------------------------------------------
    if [ -z "${CNC:-}" ]; then
        (cd "$ROOT" && cargo build --release --locked -p cnc_node --bin cnc >&2)
        CNC="$ROOT/target/release/cnc"
        rev="$(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo '?')"
        git -C "$ROOT" diff --quiet HEAD -- cnc_core cnc_node sim_axes 2>/dev/null || rev="$rev+uncommitted"
        CNC_LABEL="${CNC_LABEL:-ours $rev}"
    fi
    CNC_LABEL="${CNC_LABEL:-ours ($CNC)}"
    echo "$CNC_LABEL" > "$OUT/ours.label"
    : > "$OUT/ours.manifest"
    for p in $PROGS; do
        gen "$p" cnc836 "" "$OUT/$p.nc"
        "$CNC" check "$OUT/$p.nc" --machine mill >&2
        "$CNC" simulate "$OUT/$p.nc" --machine mill --csv "$OUT/ours_$p.csv" >&2
        printf '%s\t%s\t%s\t%s\t%s\n' "$p" "$CNC_LABEL" "as programmed (no G64)" "$OUT/$p.nc" "$OUT/ours_$p.csv" >> "$OUT/ours.manifest"
        if [ -n "$TOL" ]; then
            f="$OUT/${p}_g64_p$TOL.nc"
            gen "$p" cnc836 "G64 P$TOL" "$f"
            if "$CNC" check "$f" --machine mill > "$OUT/check_g64.txt" 2>&1; then
                "$CNC" simulate "$f" --machine mill --csv "$OUT/ours_${p}_g64_p$TOL.csv" >&2
                printf '%s\t%s\t%s\t%s\t%s\n' "$p" "$CNC_LABEL" "G64 P$TOL" "$f" "$OUT/ours_${p}_g64_p$TOL.csv" >> "$OUT/ours.manifest"
            else
                say "ours with G64 P$TOL skipped for $p: cnc check refuses it:"
                head -3 "$OUT/check_g64.txt" >&2
                echo "$p: ours with G64 P$TOL skipped, cnc check refuses it: $(head -1 "$OUT/check_g64.txt")" >> "$NOTES"
            fi
        fi
    done

    # ---- LinuxCNC ------------------------------------------------------------
    if [ $OURS_ONLY = 0 ]; then
        : > "$OUT/linuxcnc.manifest"
        LCNC_VER="$(dpkg-query -W -f '${Version}' linuxcnc-uspace 2>/dev/null || echo 2.9)"
        LCNC_VER="${LCNC_VER%%+*}"   # 2.9.0~pre1+git20230208... -> 2.9.0~pre1
        echo "LinuxCNC $LCNC_VER" > "$OUT/linuxcnc.label"
        for p in $PROGS; do
            while read -r mode; do
                [ -n "$mode" ] || continue
                n="$(lmode_name "$mode")"
                f="$OUT/${p}_lcnc_$n.ngc"
                gen "$p" linuxcnc "$mode" "$f"
                ok=0
                for try in 1 2; do
                    say "LinuxCNC: $p, $mode (try $try)"
                    if BENCH_TIMEOUT="${BENCH_TIMEOUT:-300}" bash "$ROOT/bench/linuxcnc/run.sh" "$f" "$OUT/lcnc_${p}_$n.tsv" 2> "$OUT/lcnc_${p}_$n.log"; then
                        ok=1; break
                    fi
                    tail -5 "$OUT/lcnc_${p}_$n.log" >&2
                done
                [ $ok = 1 ] || { say "LinuxCNC failed twice on $p $mode; see $OUT/lcnc_${p}_$n.log"; exit 1; }
                grep -E '^(bench: done|run.sh: wall)' "$OUT/lcnc_${p}_$n.log" >&2 || true
                printf '%s\t%s\t%s\t%s\t%s\n' "$p" "$(cat "$OUT/linuxcnc.label")" "$mode" "$f" "$OUT/lcnc_${p}_$n.tsv" >> "$OUT/linuxcnc.manifest"
            done < <(lcnc_modes "$p")
        done
    fi
fi

# ---- table ---------------------------------------------------------------------
: > "$MANIFEST"
for p in $PROGS; do
    [ -f "$OUT/linuxcnc.manifest" ] && awk -F'\t' -v p="$p" '$1 == p' "$OUT/linuxcnc.manifest" | while IFS=$'\t' read -r a b c d e; do
        [ -f "$e" ] && printf '%s\t%s\t%s\t%s\t%s\n' "$a" "$b" "$c" "$d" "$e"
    done >> "$MANIFEST"
    awk -F'\t' -v p="$p" '$1 == p' "$OUT/ours.manifest" >> "$MANIFEST"
done
"$PY" "$HERE/analyse.py" --table "$MANIFEST" --json "$OUT/results.json" > "$OUT/table.md"
echo
cat "$OUT/table.md"
[ -s "$NOTES" ] && { echo; cat "$NOTES"; }
say "done in $(( $(date +%s) - T0 )) s; outputs in $OUT (table.md, results.json, TSV/CSV samples)"

#!/usr/bin/env bash
# Benchmark `cnc check` against LinuxCNC's standalone interpreter `rs274` on
# the same generated program: blocks per second and peak memory (max RSS).
#
#   bash bench/check_vs_rs274.sh [BLOCKS]        # default 1000000
#
# Environment: REPS (default 3) timed runs per tool, best wall time and the
# largest max RSS are reported; SEED (default 1) for gen_program.py;
# SKIP_BUILD=1 skips the cargo build; CNC=path overrides target/release/cnc.
# Installs linuxcnc-uspace (rs274) and GNU time with apt if missing
# (~350 MB download, ~1.4 GB on disk, ~1.5 min). The generated program goes
# to bench/out/ (gitignored).
set -euo pipefail

BLOCKS="${1:-1000000}"
REPS="${REPS:-3}"
SEED="${SEED:-1}"
cd "$(dirname "${BASH_SOURCE[0]}")/.."   # repo root
export LC_ALL=C

OUT=bench/out
PROG="$OUT/prog_${BLOCKS}_s${SEED}.ngc"
TBL=bench/rs274.tbl
CNC="${CNC:-target/release/cnc}"
MACHINE=config/mill.toml
mkdir -p "$OUT"

say() { printf '%s\n' "$*" >&2; }

# ---- tools ---------------------------------------------------------------
need=()
command -v rs274 >/dev/null 2>&1 || need+=(linuxcnc-uspace)
[ -x /usr/bin/time ] || need+=(time)
if [ "${#need[@]}" -gt 0 ]; then
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    say "installing: ${need[*]}"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need[@]}" >/dev/null
fi

if [ "${SKIP_BUILD:-0}" != 1 ]; then
    say "building: cargo build --release -p cnc_node --bin cnc"
    if ! cargo build --release -p cnc_node --bin cnc >&2; then
        say "WARNING: cargo build failed; 'cnc check' will be skipped if $CNC is missing"
    fi
fi

# ---- program ---------------------------------------------------------------
if [ ! -s "$PROG" ]; then
    python3 bench/gen_program.py --blocks "$BLOCKS" --seed "$SEED" --out "$PROG.tmp"
    mv "$PROG.tmp" "$PROG"
fi
python3 bench/validate_program.py "$PROG" >&2
BYTES=$(stat -c %s "$PROG")
if [ "$BYTES" -gt 67108864 ]; then
    say "WARNING: $PROG is $BYTES bytes, over mill.toml [limits] max_program_bytes (64 MiB)"
fi

# ---- correctness gates (also warm the page cache) -----------------------------
# rs274 must interpret the whole file: exit 0 and one canonical
# STRAIGHT_FEED/ARC_FEED line per motion block.
set +e
RS_MOTION=$(rs274 -t "$TBL" -g "$PROG" 2>"$OUT/rs274.stderr" | grep -c -E 'STRAIGHT_FEED|ARC_FEED')
RS_RC=${PIPESTATUS[0]}
set -e
if [ "$RS_RC" -ne 0 ] || [ "$RS_MOTION" -ne "$BLOCKS" ]; then
    say "ERROR: rs274 exit $RS_RC, $RS_MOTION motion lines for $BLOCKS blocks:"
    tail -5 "$OUT/rs274.stderr" >&2
    exit 1
fi
say "rs274: exit 0, $RS_MOTION canonical motion lines (= blocks)"

HAVE_CNC=0
if [ -x "$CNC" ]; then
    set +e
    "$CNC" check "$PROG" --machine "$MACHINE" --dialect cnc836 >"$OUT/cnc.stdout" 2>"$OUT/cnc.stderr"
    CNC_RC=$?
    set -e
    if [ "$CNC_RC" -eq 0 ]; then
        HAVE_CNC=1
        say "cnc check: exit 0; $(tail -1 "$OUT/cnc.stdout" 2>/dev/null)"
    else
        say "WARNING: cnc check exited $CNC_RC on $PROG; not timed. First lines:"
        head -5 "$OUT/cnc.stdout" "$OUT/cnc.stderr" >&2 || true
    fi
else
    say "WARNING: $CNC not found; only rs274 is timed"
fi

# ---- timing ---------------------------------------------------------------
# run_timed NAME CMD...: one run, appends "wall_s maxrss_kib" to $OUT/NAME.times
run_timed() {
    local name=$1; shift
    local tf="$OUT/$name.time1"
    if ! /usr/bin/time -f '%e %M' -o "$tf" "$@" >/dev/null 2>"$OUT/$name.run.stderr"; then
        say "ERROR: $name run failed: $*"
        tail -5 "$OUT/$name.run.stderr" >&2
        exit 1
    fi
    tail -1 "$tf" >>"$OUT/$name.times"
}

rm -f "$OUT/cnc.times" "$OUT/rs274.times"
for ((r = 1; r <= REPS; r++)); do   # interleaved, so drift hits both alike
    if [ "$HAVE_CNC" -eq 1 ]; then
        run_timed cnc "$CNC" check "$PROG" --machine "$MACHINE" --dialect cnc836
    fi
    run_timed rs274 rs274 -t "$TBL" -g "$PROG"
    say "run $r/$REPS done"
done

# best wall (min), peak RSS (max) -> "wall kib"
summary() { awk 'NR==1{w=$1;m=$2} {if($1<w)w=$1; if($2>m)m=$2} END{print w, m}' "$1"; }

RS_VER=$(dpkg-query -W -f='${Version}' linuxcnc-uspace 2>/dev/null || echo unknown)
GIT_REV=$(git rev-parse --short HEAD 2>/dev/null || echo "no-commit")
if [ -n "$(git status --porcelain 2>/dev/null | head -1)" ]; then GIT_REV="$GIT_REV (dirty tree)"; fi
CPU=$(awk -F': ' '/model name/{print $2; exit}' /proc/cpuinfo)

echo
echo "program: $PROG ($BLOCKS motion blocks, $BYTES bytes, seed $SEED), $REPS runs each, best wall / max RSS"
echo "versions: cnc git $GIT_REV; linuxcnc-uspace $RS_VER; $(uname -sr); $(nproc) x $CPU"
echo
echo "| tool | blocks | best wall s | blocks/s | peak RSS MiB |"
echo "|---|---:|---:|---:|---:|"
row() {  # NAME WALL KIB
    awk -v n="$1" -v b="$BLOCKS" -v w="$2" -v k="$3" 'BEGIN{
        bps = (w > 0) ? sprintf("%.0f", b / w) : "inf";
        printf "| %s | %d | %.2f | %s | %.1f |\n", n, b, w, bps, k / 1024 }'
}
read -r RW RK < <(summary "$OUT/rs274.times")
if [ "$HAVE_CNC" -eq 1 ]; then
    read -r CW CK < <(summary "$OUT/cnc.times")
    row "cnc check" "$CW" "$CK"
fi
row "LinuxCNC rs274 -g" "$RW" "$RK"
if [ "$HAVE_CNC" -eq 1 ]; then
    awk -v cw="$CW" -v ck="$CK" -v rw="$RW" -v rk="$RK" 'BEGIN{
        sp = (cw > 0) ? sprintf("%.2fx", rw / cw) : "inf";
        tw = (rw > 0) ? sprintf("%.2f", cw / rw) : "inf";
        printf "| ratio ours/LinuxCNC | | %s | %s | %.2f |\n", tw, sp, ck / rk }'
fi
echo
echo "commands: $CNC check $PROG --machine $MACHINE --dialect cnc836 >/dev/null"
echo "          rs274 -t $TBL -g $PROG >/dev/null"

#!/usr/bin/env bash
# Run a G-code program in LinuxCNC's (2.9, uspace) simulator, headless, and
# record the commanded joint positions every 1 ms servo cycle into a TSV.
#
#   bench/linuxcnc/run.sh PROGRAM OUT.tsv [--lathe] [--rpm N] [--keep]
#
#   --lathe   use the XZ lathe config (lathe.ini.in/lathe.hal) instead of the
#             XYZ mill (mill.ini.in/mill.hal)
#   --rpm N   replace every S word of the program by S N (in a copy)
#   --keep    keep the run directory (INI, HAL, raw samples, logs)
#
# Environment overrides for the INI templates (@{NAME:default}@), e.g.
#   X_MAX_VEL X_MAX_ACC X_MIN X_MAX X_HOME (same for Y, Z), TRAJ_MAX_VEL,
#   TRAJ_MAX_ACC, SPINDLE_ACC (rpm/s), SPINDLE_MAX_RPM, ENCODER_COUNTS (lathe),
#   STARTUP_CODE, SAMPLER_DEPTH.
# Other: BENCH_TIMEOUT (s, default 600), BENCH_TAIL_MS (default 50),
#   TRIM=0 (keep stationary lead-in/tail rows), LINUXCNC (launcher path).
#
# Only one LinuxCNC can run per machine (/tmp/linuxcnc.lock, fixed SysV shm
# keys): leftovers of an earlier run are cleaned up first.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
usage() { sed -n '2,22p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
say() { printf 'run.sh: %s\n' "$*" >&2; }

MACHINE=mill RPM="" KEEP=0 POS=()
while [ $# -gt 0 ]; do
    case "$1" in
        --lathe) MACHINE=lathe ;;
        --mill) MACHINE=mill ;;
        --rpm) RPM="${2:?--rpm needs a value}"; shift ;;
        --rpm=*) RPM="${1#--rpm=}" ;;
        --keep) KEEP=1 ;;
        -h|--help) usage ;;
        -*) say "unknown option $1"; usage ;;
        *) POS+=("$1") ;;
    esac
    shift
done
[ "${#POS[@]}" -eq 2 ] || usage
PROGRAM="$(realpath -e "${POS[0]}")"
OUT="$(realpath -m "${POS[1]}")"
mkdir -p "$(dirname "$OUT")"
LINUXCNC="${LINUXCNC:-linuxcnc}"
PY=/usr/bin/python3          # Debian's python: has the linuxcnc and hal modules
command -v "$LINUXCNC" >/dev/null || { say "linuxcnc not found (apt-get install linuxcnc-uspace)"; exit 1; }

# ---- clean up leftovers of an earlier (crashed) run ------------------------
cleanup_leftovers() {
    local names="bench_display.py halsampler halui milltask io iocontrol linuxcncsvr rtapi_app"
    local pids="" desc="" n p
    for n in $names; do
        for p in $(pgrep -x "$n" 2>/dev/null || true); do
            # exited processes wait as zombies until PID 1 reaps them: ignore
            case "$(ps -o stat= -p "$p" 2>/dev/null)" in Z*|"") continue ;; esac
            pids="$pids $p"; desc="$desc $n[$p]"
        done
    done
    # the launcher itself: a bash running /usr/bin/linuxcnc
    for p in $(pgrep -f '^/bin/bash /usr/bin/linuxcnc ' 2>/dev/null || true); do pids="$pids $p"; desc="$desc linuxcnc[$p]"; done
    if [ -n "${pids// /}" ] || [ -e /tmp/linuxcnc.lock ]; then
        say "cleaning up leftovers:${desc:- lock file only}"
        [ -n "${pids// /}" ] && kill $pids 2>/dev/null || true
        for _ in $(seq 30); do
            alive=""
            for p in $pids; do
                case "$(ps -o stat= -p "$p" 2>/dev/null)" in Z*|"") ;; *) alive="$alive $p" ;; esac
            done
            [ -z "$alive" ] && break; sleep 0.1
        done
        [ -n "${alive:-}" ] && kill -9 $alive 2>/dev/null || true
        rm -f /tmp/linuxcnc.lock
    fi
    # SysV shm of HAL/RTAPI (fixed keys) and of NML (keys in linuxcnc.nml)
    local k
    for k in 0x48414c32 0x90280a48 0x48484c34; do ipcrm -M "$k" 2>/dev/null || true; done
    if [ -r /usr/share/linuxcnc/linuxcnc.nml ]; then
        while read -r b _ t _ _ _ _ _ _ m _; do
            [ "$b$t" = BSHMEM ] && ipcrm -M "$m" 2>/dev/null || true
        done < /usr/share/linuxcnc/linuxcnc.nml
    fi
}
cleanup_leftovers

# ---- run directory -----------------------------------------------------------
RUN="$(mktemp -d "${TMPDIR:-/tmp}/lcnc-bench.XXXXXX")"
finish() {
    local rc=$?
    if [ "$KEEP" = 1 ] || [ $rc -ne 0 ]; then say "run directory kept: $RUN"; else rm -rf "$RUN"; fi
    exit $rc
}
trap finish EXIT
cp "$HERE/$MACHINE.hal" "$HERE/bench_display.py" "$HERE/tool.tbl" "$RUN/"
: > "$RUN/sim.var"
# rtapi_app refuses to run as root unless RTAPI_UID names a non-root user; it
# then binds its control socket (RTAPI_FIFO_PATH, default $HOME/.rtapi_fifo)
# with that uid, so the socket's directory must be writable by it.
chmod 755 "$RUN"
mkdir -m 1777 "$RUN/rtapi"
BENCH_DIR="$RUN" "$PY" - "$HERE/$MACHINE.ini.in" "$RUN/bench.ini" <<'PYEOF'
import os, re, sys
src = open(sys.argv[1]).read()
def sub(m):
    return os.environ.get(m.group(1), m.group(2))
m = re.search(r"@\{ENCODER_COUNTS:([^}]*)\}@", src)
if m and not os.environ.get("ENCODER_SCALE"):
    os.environ["ENCODER_SCALE"] = repr(1.0 / float(os.environ.get("ENCODER_COUNTS", m.group(1))))
open(sys.argv[2], "w").write(re.sub(r"@\{(\w+):([^}]*)\}@", sub, src))
PYEOF

PROG_RUN="$RUN/program.ngc"
if [ -n "$RPM" ]; then
    "$PY" - "$PROGRAM" "$PROG_RUN" "$RPM" <<'PYEOF'
import re, sys
src, dst, rpm = sys.argv[1], sys.argv[2], sys.argv[3]
n = 0
out = []
for line in open(src):
    # leave (comments) and ;comments alone
    parts = re.split(r"(\([^)]*\)|;.*$)", line.rstrip("\n"))
    for i in range(0, len(parts), 2):
        parts[i], k = re.subn(r"([Ss])\s*[-+]?(\d+\.?\d*|\.\d+|\[[^\]]*\]|#<?\w+>?)", r"\g<1>" + rpm, parts[i])
        n += k
    out.append("".join(parts) + "\n")
open(dst, "w").writelines(out)
print(f"run.sh: --rpm {rpm}: replaced {n} S word(s)", file=sys.stderr)
if n == 0:
    sys.exit("run.sh: --rpm given but the program has no S word")
PYEOF
else
    cp "$PROGRAM" "$PROG_RUN"
fi

# ---- run ---------------------------------------------------------------------
say "machine=$MACHINE program=$PROGRAM${RPM:+ rpm=$RPM} run=$RUN"
T0=$(date +%s.%N)
set +e
(
    cd "$RUN"
    unset DISPLAY             # no X: also stops the launcher from asking via wish
    # the launcher copies its logs to $HOME/linuxcnc_{debug,print}.txt on error
    export HOME="$RUN"
    export RTAPI_FIFO_PATH="$RUN/rtapi/fifo"
    if [ "$(id -u)" -eq 0 ]; then export RTAPI_UID="${RTAPI_UID:-${SUDO_UID:-65534}}"; fi
    export BENCH_PROGRAM="$PROG_RUN" BENCH_RAW="$RUN/samples.raw" BENCH_LOG="$RUN/bench.log"
    export BENCH_TIMEOUT="${BENCH_TIMEOUT:-600}" BENCH_TAIL_MS="${BENCH_TAIL_MS:-50}"
    exec timeout -s TERM -k 20 "$(( ${BENCH_TIMEOUT:-600} + 60 ))" \
        "$LINUXCNC" "$RUN/bench.ini" </dev/null >"$RUN/linuxcnc.log" 2>&1
)
RC=$?
set -e
T1=$(date +%s.%N)
cat "$RUN/bench.log" >&2 2>/dev/null || true
if [ $RC -ne 0 ] || ! grep -q '^bench: done' "$RUN/bench.log" 2>/dev/null; then
    say "LinuxCNC run failed (exit $RC); launcher logs (only kept on failure):"
    for f in "$RUN"/linuxcnc_debug.txt "$RUN"/linuxcnc_print.txt; do
        [ -f "$f" ] && { say "--- $f"; grep -v -e '^+' -e 'fallback_uid' "$f" | tail -n 25 >&2; }
    done
    cleanup_leftovers
    exit 1
fi
[ -e /tmp/linuxcnc.lock ] && { say "warning: lock file left behind"; cleanup_leftovers; }
say "wall time $(awk -v a="$T0" -v b="$T1" 'BEGIN{printf "%.2f", b-a}') s (start, home, run, shutdown)"

TRIMARG=""; [ "${TRIM:-1}" = 0 ] && TRIMARG="--no-trim"
"$PY" "$HERE/sampler2tsv.py" "$RUN/samples.raw" "$OUT" $TRIMARG

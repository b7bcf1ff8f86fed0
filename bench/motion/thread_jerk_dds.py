"""The jerk of a G33 job over DDS (issue 17): the release nodes of
scripts/main_job.sh (sim_axes and cnc_node, the bundled lathe, its
4096-count encoder), one recorded job of `examples/lathe_thread.nc`
(`cnc run --record`), and from the recording:

- the setpoints' largest |a| and |j| per joint (finite differences at the
  1 ms sample period), the 99.9th percentile of |j| and the samples over
  the machine's jerk limit, on the whole job and on the thread passes
  alone (the samples on a G33 line, from the job's status);
- the same of the simulated axes' positions (/sim/joint_states): what
  the drive model does with those setpoints.

The offline figures of the same program are `thread_jerk.py`'s.

    . .venv-ros/env.sh
    python3 bench/motion/thread_jerk_dds.py [--bin target/release] [--domain 58] [--ripple 0.02]
"""

import argparse
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from thread_jerk import series_stats

ROOT = pathlib.Path(__file__).resolve().parents[2]
DT = 0.001
PROGRAM = ROOT / "examples" / "lathe_thread.nc"
# G33 lines of the program (its text's 1-based line numbers)
G33_LINES = {
    i + 1 for i, line in enumerate(PROGRAM.read_text().splitlines()) if re.search(r"\bG33\b", line)
}


def limits():
    """Each joint's jerk limit, m/s³, from config/lathe.toml (x, z)."""
    text = (ROOT / "config" / "lathe.toml").read_text()
    out = {}
    for block in text.split("[[axis]]")[1:]:
        name = re.search(r'name = "(\w+)"', block).group(1)
        out[name] = float(re.search(r"max_jerk_mm_s3 = ([0-9.e+]+)", block).group(1)) / 1000.0
    return out


def series(path):
    """Setpoints and joint states as {joint: [position mm]} (the topics
    carry metres), the
    program line each setpoint belongs to (the last status before it), and
    the joint states' stamps (s)."""
    set_pos, act_pos, lines, act_t = {}, {}, [], []
    line = 0
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, ch, _, msg in reader.iter_decoded_messages(log_time_order=True):
            if ch.topic == "/cnc/status":
                line = int(msg.source_line)
            elif ch.topic == "/cnc/joint_setpoints":
                for n, p in zip(msg.name, msg.position):
                    set_pos.setdefault(n, []).append(p * 1000.0)
                lines.append(line)
            elif ch.topic == "/sim/joint_states":
                for n, p in zip(msg.name, msg.position):
                    act_pos.setdefault(n, []).append(p * 1000.0)
                act_t.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
    return set_pos, act_pos, lines, act_t


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=str(ROOT / "target" / "release"))
    ap.add_argument("--domain", default=os.environ.get("ROS_DOMAIN_ID", "58"))
    ap.add_argument("--ripple", type=float, default=None,
                    help="the simulated spindle's speed ripple at 5 Hz, a fraction (default: the machine file's)")
    a = ap.parse_args()
    env = dict(os.environ, ROS_DOMAIN_ID=str(a.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    out = pathlib.Path(tempfile.mkdtemp(prefix="thread_jerk_dds_"))
    rec_dir = out / "recordings"
    binp = pathlib.Path(a.bin)
    ripple = [] if a.ripple is None else ["--ripple", str(a.ripple)]
    sim = subprocess.Popen([binp / "sim_axes", "--machine", "lathe", *ripple], env=env,
                           stderr=open(out / "sim_axes.log", "w"))
    node = subprocess.Popen([binp / "cnc_node", "--machine", "lathe", "--record-dir", str(rec_dir)],
                            env=env, stderr=open(out / "cnc_node.log", "w"))
    try:
        time.sleep(3)
        r = subprocess.run([binp / "cnc", "run", str(PROGRAM), "--record"], env=env,
                           capture_output=True, text=True, timeout=120)
        print(r.stdout.strip().splitlines()[-1] if r.stdout.strip() else r.stderr.strip())
    finally:
        for p in (node, sim):
            p.terminate()
        for p in (node, sim):
            p.wait(timeout=10)
    recs = sorted(rec_dir.glob("*.mcap"))
    if not recs:
        sys.exit(f"no recording in {rec_dir} (logs in {out})")
    set_pos, act_pos, lines, act_t = series(recs[-1])
    lim = limits()
    print(f"recording {recs[-1]} ({len(lines)} setpoints); jerk limits {lim} m/s³")
    print("| series | part | joint | max \\|a\\| mm/s² | max \\|j\\| (p99.9) m/s³ | samples over |")
    print("|---|---|---|---:|---:|---:|")
    on_thread = lambda k: all(lines[i] in G33_LINES for i in range(k - 3, k + 1))  # noqa: E731
    # (the joint states' differences only over four samples a period apart:
    # the recording's first state may come before a gap)
    on_grid = lambda k: k >= 3 and all(  # noqa: E731
        abs(act_t[i] - act_t[i - 1] - DT) < 0.1 * DT for i in range(k - 2, k + 1))
    for name, pos in (("setpoints", set_pos), ("simulated axes", act_pos)):
        for part, keep in (("whole job", None), ("G33 lines", on_thread)):
            for j in sorted(pos):
                if j not in lim:
                    continue
                s = series_stats(pos[j], lim[j] * 1000.0, DT, keep if name == "setpoints" else on_grid)
                if s is None or (name != "setpoints" and part != "whole job"):
                    continue
                print(f"| {name} | {part} | {j} | {s[0]:.0f} | {s[1]:.1f} ({s[2]:.1f}) | {s[3]} |")


if __name__ == "__main__":
    main()

"""The path planner (`[planner] method = "path"`) in the real node: a
mill whose machine file plans with it runs a job of lines and an arc under
`G64 P0.01` through `cnc run`, held while it moves (`cnc hold`), the
override set to 50 % and resumed (`cnc resume`). The node plans on threads
of its own ahead of its 1 kHz loop (`Executor::plan_ahead`); what it
published, from its recording of the job, is judged by the setpoints'
finite differences at the 1 ms period (every axis's velocity,
acceleration and jerk within the machine file's), their distance from the
programmed path (within P), the hold (the axes stood still) and the end
(exactly on the last point). The controller's state comes from an rclpy
peer's subscription to the status (SingleThreadedExecutor).

    scripts/ros_peer/setup.sh && . .venv-ros/env.sh && python3 -m pytest tests/ros/test_path_planner.py
"""
import math
import os
import re
import shutil
import subprocess
import time

import pytest

from cnc_msgs.msg import ControllerStatus
from ros_nodes import ROOT, TARGET, cnc, domain, job_recording, session, status_peer

DOMAIN = domain(8)
RECORDINGS = os.path.join(ROOT, "target", "test-recordings-path")
JERK = 50000.0  # mm/s³: 50 m/s³, a real mill's
VMAX, AMAX = 250.0, 2000.0  # config/mill.toml's X and Y

# X20 Y0 -> X60 -> an R10 quarter arc -> Y50, under P 0.01, at 100 mm/s
PROGRAM = "G17 G90 G64 P0.01\nG00 X20 Y0 Z0\nG01 X60 F6000\nG03 X70 Y10 I0 J10\nG01 Y50\nM30\n"


def machine_file(tmp):
    """config/mill.toml planned by the path planner at 50 m/s³."""
    text = open(os.path.join(ROOT, "config", "mill.toml")).read()
    text = re.sub(r"(?m)^lookahead_blocks = (.*)$", r'lookahead_blocks = \1\nmethod = "path"', text)
    text = re.sub(r"(?m)^max_jerk_mm_s3 = .*$", "max_jerk_mm_s3 = %.1f" % JERK, text)
    text = re.sub(r'(?m)^program_dir = .*$', 'program_dir = "%s"' % os.path.join(ROOT, "examples"), text)
    assert 'method = "path"' in text
    path = os.path.join(tmp, "mill_path.toml")
    with open(path, "w") as f:
        f.write(text)
    return path


@pytest.fixture(scope="module")
def env(tmp_path_factory):
    shutil.rmtree(RECORDINGS, ignore_errors=True)
    m = machine_file(str(tmp_path_factory.mktemp("path_machine")))
    yield from session(DOMAIN, ["--machine", "mill"], ["--machine", m, "--record-dir", RECORDINGS])


@pytest.fixture
def peer(env):
    yield from status_peer("path_peer")


def off_path(p):
    """Distance (mm) of point p (x, y) from the programmed path after the
    rapid: X20..60 at Y0, the R10 arc about (60, 10), X70 Y10..50."""
    x, y = p
    d = math.hypot(x - min(max(x, 20.0), 60.0), y)
    a = math.atan2(y - 10.0, x - 60.0)
    if -math.pi / 2 <= a <= 0.0:
        d = min(d, abs(math.hypot(x - 60.0, y - 10.0) - 10.0))
    return min(d, math.hypot(x - 70.0, y - min(max(y, 10.0), 50.0)))


def test_a_path_planner_job_held_and_resumed_at_half_feed_keeps_every_limit_and_the_path(env, peer, tmp_path):
    prog = tmp_path / "path.nc"
    prog.write_text(PROGRAM)
    run = subprocess.Popen([os.path.join(TARGET, "cnc"), "run", str(prog), "--wait", "30", "--record"], cwd=ROOT,
                           env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    st = peer.wait_state(ControllerStatus.STATE_RUNNING, 30.0)
    job = st.job_id
    time.sleep(0.6)  # (moving)
    rc, out, err = cnc(env, "hold")
    assert rc == 0, err
    peer.wait_state(ControllerStatus.STATE_HOLD, 10.0)
    time.sleep(1.0)
    rc, out, err = cnc(env, "override", "50")
    assert rc == 0, err
    rc, out, err = cnc(env, "resume")
    assert rc == 0, err
    out, err = run.communicate(timeout=120)
    assert run.returncode == 0, err
    assert "job %d done" % job in out, out
    time.sleep(1.5)  # (the recording is closed after the job)
    rec = job_recording(RECORDINGS, job)
    pos = [[q * 1000.0 for q in m.position] for _, m in rec["/cnc/joint_setpoints"]]
    assert len(pos) > 1000, len(pos)
    # exactly on the last point
    assert [round(c, 9) for c in pos[-1]] == [70.0, 50.0, 0.0], pos[-1]
    # every axis within its limits at the 1 ms period (the setpoints in
    # the order published; 1e-6 for the float32-free doubles' rounding)
    dt = 0.001
    worst = [0.0, 0.0, 0.0]
    for k in range(3, len(pos)):
        for i in range(3):
            p0, p1, p2, p3 = pos[k - 3][i], pos[k - 2][i], pos[k - 1][i], pos[k][i]
            v = (p3 - p2) / dt
            a = (p3 - 2 * p2 + p1) / dt ** 2
            j = (p3 - 3 * p2 + 3 * p1 - p0) / dt ** 3
            worst = [max(worst[0], abs(v) / VMAX), max(worst[1], abs(a) / AMAX), max(worst[2], abs(j) / JERK)]
    assert max(worst) <= 1.0 + 1e-6, "share of the limits reached (v, a, j): %s" % worst
    # the hold stood still for most of a second, between the first motion
    # and the end; resumed at 50 % of F6000 at once: 50 mm/s at most after,
    # and reached
    first = next(k for k in range(1, len(pos)) if pos[k] != pos[k - 1])
    last = next(k for k in range(len(pos) - 1, 0, -1) if pos[k] != pos[k - 1])
    still, longest, held_end = 0, 0, first
    for k in range(first, last + 1):
        still = still + 1 if pos[k] == pos[k - 1] else 0
        if still > longest:
            longest, held_end = still, k
    assert longest > 500, longest
    after = [math.dist(pos[k], pos[k - 1]) / dt for k in range(held_end + 1, len(pos))]
    assert max(after) <= 50.0 + 1e-6, max(after)
    assert max(after) > 49.0, max(after)
    # within P of the programmed path once past the rapid (on X20 Y0)
    start = next(k for k, p in enumerate(pos) if p[0] > 20.0 + 1e-6 and abs(p[1]) < 0.01)
    dev = max(off_path((p[0], p[1])) for p in pos[start:])
    assert dev <= 0.01 + 1e-9, dev

"""`cnc abort|hold|resume|override|status` and `cnc run` against the real
nodes, as a user types them: a hold longer than the old give-up time
(estimate x 3 + 30 s) keeps `cnc run` waiting, the override shows in the
status, Ctrl-C (SIGINT) in `cnc run` aborts the job on its path. The
controller's state is judged by an rclpy peer's subscription to the status
(SingleThreadedExecutor), where the axes stopped by the node's recording of
the job, the CLI by its exit code and text.

    scripts/ros_peer/setup.sh && . .venv-ros/env.sh && python3 -m pytest tests/ros/test_cli_control.py
"""
import os
import shutil
import signal
import subprocess
import time

import pytest
import rclpy

from cnc_msgs.msg import ControllerStatus
from ros_nodes import ROOT, TARGET, build, cnc, domain, job_recording, start, status_peer, stop

DOMAIN = domain(4)
RECORDINGS = os.path.join(ROOT, "target", "test-recordings-cli")


@pytest.fixture(scope="module")
def env():
    e = dict(os.environ, ROS_DOMAIN_ID=DOMAIN, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    shutil.rmtree(RECORDINGS, ignore_errors=True)  # job ids start at 1 with every node
    build()
    procs = start(e, ["--machine", "mill"], ["--machine", "mill", "--record-dir", RECORDINGS])
    os.environ["ROS_DOMAIN_ID"] = DOMAIN
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    rclpy.init()
    yield e
    rclpy.shutdown()
    stop(procs)


@pytest.fixture
def peer(env):
    # (a peer whose reader the node never matched is made again as a
    # participant of its own: ros_nodes.hearing_peer; CI once saw this
    # module's peers hear no status for 30 s, three tests in a row)
    yield from status_peer("cli_peer")


def start_run(env, tmp_path, text, name="job.nc"):
    """`cnc run --record` of `text` in the background."""
    prog = tmp_path / name
    prog.write_text(text)
    return subprocess.Popen([os.path.join(TARGET, "cnc"), "run", str(prog), "--wait", "30", "--record"], cwd=ROOT,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def last_setpoint(job_id):
    """The last setpoint (mm) of a job, from the node's recording of it
    (every setpoint it published, by its stamp)."""
    rec = job_recording(RECORDINGS, job_id)
    return [p * 1000.0 for p in rec["/cnc/joint_setpoints"][-1][1].position]


def test_hold_longer_than_the_old_give_up_then_override_and_resume(env, peer, tmp_path):
    # estimated about 6.1 s: the old client gave up after 3 x 6.1 + 30 = 48 s;
    # the hold comes during the dwell
    run = start_run(env, tmp_path, "G04 P4\nG90 G01 X20 F600\nM30\n")
    st = peer.wait_state(ControllerStatus.STATE_RUNNING, 30.0)
    job = st.job_id
    rc, out, err = cnc(env, "hold")
    assert rc == 0, err
    st = peer.wait_state(ControllerStatus.STATE_HOLD, 10.0)
    assert st.job_id == job
    rc, out, err = cnc(env, "status")
    assert rc == 0, err
    assert out.startswith("HOLD job %d line 1" % job), out
    time.sleep(50.0)
    assert run.poll() is None, "cnc run gave up during the hold: " + run.stderr.read()
    rc, out, err = cnc(env, "override", "50")
    assert (rc, out.strip()) == (0, "feed override 50 %"), err
    peer.wait_for("the override in the status",
                  lambda: bool(peer.status) and abs(peer.status[-1].feed_override - 0.5) < 1e-12, 10.0)
    rc, out, err = cnc(env, "resume")
    assert rc == 0, err
    out, err = run.communicate(timeout=60)
    assert run.returncode == 0, err
    assert "job %d done" % job in out, out
    time.sleep(1.5)  # (the recording is closed after the job)
    assert abs(last_setpoint(job)[0] - 20.0) < 1e-9
    rc, out, err = cnc(env, "override", "100")
    assert rc == 0, err
    rc, out, err = cnc(env, "override", "500")
    assert rc == 2 and "must be between 0 and 200 %" in err, (rc, err)


def test_ctrl_c_in_cnc_run_aborts_the_job_on_its_path(env, peer, tmp_path):
    # 400 mm at 10 mm/s: 40 s, interrupted after about a second of motion
    run = start_run(env, tmp_path, "G90 G00 X0 Y0\nG01 X400 F600\nM30\n")
    st = peer.wait_state(ControllerStatus.STATE_RUNNING, 30.0)
    peer.wait_for("line 2", lambda: bool(peer.status) and peer.status[-1].source_line == 2, 30.0)
    time.sleep(1.0)
    run.send_signal(signal.SIGINT)
    out, err = run.communicate(timeout=30)
    assert run.returncode == 130, (run.returncode, out, err)
    assert "aborted (Ctrl-C) at line 2" in err, err
    peer.wait_state(ControllerStatus.STATE_IDLE, 10.0)
    time.sleep(1.5)
    x, y, _ = last_setpoint(st.job_id)
    # stopped on the path, far from the end (the line takes 40 s)
    assert 5.0 < x < 100.0, x
    assert abs(y) < 1e-9
    rc, out, _ = cnc(env, "status")
    assert out.startswith("IDLE job %d" % st.job_id), out


def test_the_dialect_comes_from_the_file_name(env, peer, tmp_path):
    run = start_run(env, tmp_path, "N10 I+50 J+50 F600 *\nN20 G11 R+10 H+0 *\nN30 M30 *\n", name="polar.h")
    out, err = run.communicate(timeout=60)
    assert run.returncode == 0, err
    job = int(out.split("job ")[1].split()[0])
    time.sleep(1.5)
    x, y, _ = last_setpoint(job)
    assert abs(x - 60.0) < 1e-9 and abs(y - 50.0) < 1e-9, (x, y)


def test_no_controller_is_a_clear_error(env):
    rc, out, err = cnc(env, "status", "--namespace", "/nobody", "--wait", "1")
    assert rc == 2
    assert "no status from /nobody/status within 1 s" in err, err

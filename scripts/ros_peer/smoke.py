#!/usr/bin/env python3
"""Smoke test of the ROS 2 peer environment built by setup.sh.

In one process with rclpy:
  * node "cnc_smoke_server" serves cnc_msgs/srv/RunProgram on /cnc/run_program
    and publishes cnc_msgs/msg/ControllerStatus on /cnc/status,
    sensor_msgs/msg/JointState on /joint_states and
    cnc_msgs/msg/SpindleEncoder on /cnc/spindle_encoder;
  * node "cnc_smoke_client" calls the service and subscribes to the three
    topics, all with default QoS (reliable, keep last 10, volatile).

Exits 0 when the service answered and every topic delivered a message,
1 otherwise. Usage (after setup.sh):

    . .venv-ros/env.sh && python3 scripts/ros_peer/smoke.py [--timeout S]

--role server / --role client run only one side (the server side serves and
publishes until --timeout), so the two halves can run in two processes, or
against the Rust node, over the wire.
"""

import argparse
import sys
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from builtin_interfaces.msg import Time
from cnc_msgs.msg import ControllerStatus, SpindleEncoder
from cnc_msgs.srv import RunProgram
from sensor_msgs.msg import JointState

QOS_DEPTH = 10  # rclpy default profile: reliable, keep last 10, volatile


class Server(Node):
    def __init__(self):
        super().__init__("cnc_smoke_server")
        self.next_job = 41
        self.srv = self.create_service(RunProgram, "/cnc/run_program", self.on_run)
        self.status_pub = self.create_publisher(ControllerStatus, "/cnc/status", QOS_DEPTH)
        self.joint_pub = self.create_publisher(JointState, "/joint_states", QOS_DEPTH)
        self.enc_pub = self.create_publisher(SpindleEncoder, "/cnc/spindle_encoder", QOS_DEPTH)

    def on_run(self, req, resp):
        self.get_logger().info(
            f"RunProgram request: program={req.program!r} path={req.program_path!r} "
            f"dialect={req.dialect!r} dry_run={req.dry_run}")
        self.next_job += 1
        lines = [l for l in req.program.splitlines() if l.strip()]
        resp.accepted = bool(lines)
        resp.message = "" if lines else "line 1, column 1: empty program"
        resp.job_id = self.next_job
        resp.estimated_duration = 0.5 * len(lines)
        return resp

    def publish_all(self, seq):
        now = self.get_clock().now().to_msg()
        st = ControllerStatus()
        st.header.stamp = now
        st.header.frame_id = ""
        st.state = ControllerStatus.STATE_RUNNING
        st.job_id = self.next_job
        st.source_line = 3
        st.block_number = 30
        st.active_g_codes = ["G1", "G17", "G21", "G90", "G94"]
        st.active_tool = 7
        st.spindle_speed_command = 1200.0
        st.feed_override = 1.0
        st.progress = 0.25
        st.last_error = ""
        self.status_pub.publish(st)

        js = JointState()
        js.header.stamp = now
        js.name = ["x", "y", "z", "spindle"]
        js.position = [1.0, 2.0, 3.0 + seq, 0.5]
        js.velocity = [0.0, 0.0, 0.1, 125.66]
        js.effort = []
        self.joint_pub.publish(js)

        enc = SpindleEncoder()
        enc.stamp = Time(sec=now.sec, nanosec=now.nanosec)
        enc.count = -4096 * seq - 17
        enc.counts_per_rev = 4096
        enc.index_count = seq
        enc.count_at_index = -4096 * seq
        enc.velocity = 125.66
        self.enc_pub.publish(enc)


class Client(Node):
    def __init__(self):
        super().__init__("cnc_smoke_client")
        self.cli = self.create_client(RunProgram, "/cnc/run_program")
        self.got = {}
        self.create_subscription(ControllerStatus, "/cnc/status",
                                 lambda m: self.got.setdefault("status", m), QOS_DEPTH)
        self.create_subscription(JointState, "/joint_states",
                                 lambda m: self.got.setdefault("joint_states", m), QOS_DEPTH)
        self.create_subscription(SpindleEncoder, "/cnc/spindle_encoder",
                                 lambda m: self.got.setdefault("spindle_encoder", m), QOS_DEPTH)


def spin_until(executor, cond, deadline, tick=None, period=0.1):
    last = 0.0
    while not cond():
        if time.monotonic() > deadline:
            return False
        if tick is not None and time.monotonic() - last >= period:
            tick()
            last = time.monotonic()
        executor.spin_once(timeout_sec=0.05)
    return True


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--timeout", type=float, default=20.0)
    ap.add_argument("--role", choices=("both", "server", "client"), default="both")
    args = ap.parse_args()

    t0 = time.monotonic()
    deadline = t0 + args.timeout
    rclpy.init()
    ok = True
    try:
        from rclpy.utilities import get_rmw_implementation_identifier
        print(f"rmw: {get_rmw_implementation_identifier()}, role: {args.role}", flush=True)
        ex = SingleThreadedExecutor()
        if args.role == "server":
            server = Server()
            ex.add_node(server)
            n = [0]

            def tick():
                n[0] += 1
                server.publish_all(n[0])
            spin_until(ex, lambda: False, deadline, tick=tick)
            print(f"server: published {n[0]} rounds, served job ids up to {server.next_job}")
            return 0
        client = Client()
        ex.add_node(client)
        server = Server() if args.role == "both" else None
        if server is not None:
            ex.add_node(server)

        # --- service: the client in the other node calls the server ---
        if not spin_until(ex, lambda: client.cli.service_is_ready(), deadline):
            print("FAIL: service /cnc/run_program not discovered")
            return 1
        results = []
        for req in (RunProgram.Request(program="G0 X0 Y0\nG1 X10 F100\nM30\n", dialect="cnc836", dry_run=True),
                    RunProgram.Request(program="", program_path="", dialect="", dry_run=False)):
            fut = client.cli.call_async(req)
            if not spin_until(ex, fut.done, deadline):
                print("FAIL: no RunProgram response")
                return 1
            results.append(fut.result())
            print(f"service response: {fut.result()}")
        r_ok, r_bad = results
        if not (r_ok.accepted and r_bad.job_id == r_ok.job_id + 1 and abs(r_ok.estimated_duration - 1.5) < 1e-9
                and not r_bad.accepted and r_bad.message.startswith("line 1, column 1:")):
            print("FAIL: unexpected service responses")
            ok = False

        # --- topics: publish until every subscription has seen a message ---
        seq = [0]

        def tick():
            seq[0] += 1
            if server is not None:
                server.publish_all(seq[0])

        want = {"status", "joint_states", "spindle_encoder"}
        if not spin_until(ex, lambda: want <= client.got.keys(), deadline, tick=tick):
            print(f"FAIL: received only {sorted(client.got)} after {seq[0]} publications")
            return 1
        for k in sorted(client.got):
            print(f"received {k}: {client.got[k]}")
        st = client.got["status"]
        if not (st.state == ControllerStatus.STATE_RUNNING and st.active_g_codes[0] == "G1"
                and st.block_number == 30 and client.got["joint_states"].name[-1] == "spindle"
                and client.got["spindle_encoder"].counts_per_rev == 4096):
            print("FAIL: received data differ from what was sent")
            ok = False
        rounds = f" ({seq[0]} publication rounds)" if server is not None else ""
        print(f"{'OK' if ok else 'FAIL'}: smoke test in {time.monotonic() - t0:.2f} s{rounds}")
        return 0 if ok else 1
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())

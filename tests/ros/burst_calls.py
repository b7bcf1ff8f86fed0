"""A burst of service calls from its own process (so the caller's Python
does not slow the test's subscriber): N calls of /NS/run_program with a
small program, spread over C rclpy clients (one node each), at most W in
flight per client (an rclpy client keeps the last 10 requests it sent: more
in flight could lose some in its own history, whatever the server does).

    python3 burst_calls.py NAMESPACE N C W  -> one JSON line:
    {"sent": N, "answered": ..., "messages": {message: count}, "accepted": ...,
     "t0": wall s, "t1": wall s, "missing": [...]}
"""
import json
import sys
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile

from cnc_msgs.srv import RunProgram

ns, total, nclients, window = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
depth = int(sys.argv[5]) if len(sys.argv) > 5 else 10
rclpy.init()
ex = SingleThreadedExecutor()
clients = []
for i in range(nclients):
    node = rclpy.create_node("burst_%d_%d" % (i, time.time_ns() % 1_000_000))
    ex.add_node(node)
    clients.append(node.create_client(RunProgram, ns + "/run_program", qos_profile=QoSProfile(depth=depth)))
for c in clients:
    if not c.wait_for_service(timeout_sec=30.0):
        print(json.dumps({"error": "no service"}))
        sys.exit(2)
req = RunProgram.Request()
req.program = "G00 X1\n"
pending = [[] for _ in clients]  # futures in flight per client
done = []
sent = 0
t0 = time.time()
deadline = t0 + 120.0
while (sent < total or any(pending)) and time.time() < deadline:
    for i, c in enumerate(clients):
        while sent < total and len(pending[i]) < window:
            pending[i].append(c.call_async(req))
            sent += 1
    ex.spin_once(timeout_sec=0.01)
    for i in range(len(clients)):
        still = []
        for f in pending[i]:
            (done if f.done() else still).append(f)
        pending[i] = still
t1 = time.time()
messages = {}
accepted = 0
for f in done:
    r = f.result()
    if r is None:
        continue
    accepted += int(r.accepted)
    messages[r.message] = messages.get(r.message, 0) + 1
print(json.dumps({"sent": sent, "answered": sum(messages.values()), "accepted": accepted,
                  "messages": messages, "t0": t0, "t1": t1,
                  "in_flight_at_end": sum(len(p) for p in pending)}))
rclpy.shutdown()

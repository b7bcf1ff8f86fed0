"""A client that vanishes mid-call: sends one /NS/run_program request and
waits for nothing; the test kills it (SIGKILL) before the reply comes.

    python3 vanishing_call.py NAMESPACE PROGRAM_FILE
        (prints "sent" once the request is out, then sleeps)
"""
import sys
import time

import rclpy

from cnc_msgs.srv import RunProgram

rclpy.init()
node = rclpy.create_node("vanishing_%d" % (time.time_ns() % 1_000_000))
cli = node.create_client(RunProgram, sys.argv[1] + "/run_program")
if not cli.wait_for_service(timeout_sec=30.0):
    print("no service", flush=True)
    sys.exit(2)
# the service is seen from here; give the server a moment to see this
# client too (discovery goes both ways), or it may drop the request
time.sleep(1.0)
req = RunProgram.Request()
with open(sys.argv[2]) as f:
    req.program = f.read()
req.dry_run = True
cli.call_async(req)
# spin a little so the request (and its fragments) go out, then wait to die
t0 = time.time()
while time.time() - t0 < 0.2:
    rclpy.spin_once(node, timeout_sec=0.02)
print("sent", flush=True)
while True:
    time.sleep(1.0)

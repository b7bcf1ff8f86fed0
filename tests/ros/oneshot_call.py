"""A short-lived client, as `ros2 service call` is: start, call once, exit.
Usage: python3 oneshot_call.py NAMESPACE  -> prints the response, exit 0 on a reply."""
import sys
import time

import rclpy
from cnc_msgs.srv import RunProgram

rclpy.init()
node = rclpy.create_node("oneshot_%d" % (time.time_ns() % 1_000_000))
cli = node.create_client(RunProgram, sys.argv[1] + "/run_program")
if not cli.wait_for_service(timeout_sec=20.0):
    print("no service")
    sys.exit(2)
req = RunProgram.Request()
req.program = "G00 X10 Y10\nG01 X20 F600\n"
req.dry_run = True
fut = cli.call_async(req)
rclpy.spin_until_future_complete(node, fut, timeout_sec=20.0)
if not fut.done() or fut.result() is None:
    print("no reply")
    sys.exit(3)
r = fut.result()
print("accepted=%s estimated=%.3f message=%r" % (r.accepted, r.estimated_duration, r.message))
node.destroy_node()
rclpy.shutdown()

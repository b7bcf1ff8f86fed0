"""What `ros2 node list --no-daemon` and `ros2 topic list -t` do: a fresh
participant asks the graph. Prints the nodes and the topic types as JSON
once both of our nodes are seen (or after 15 s)."""
import json
import sys
import time

import rclpy

rclpy.init()
node = rclpy.create_node("node_list_probe")
want = {("cnc_node", sys.argv[1]), ("sim_axes", sys.argv[2])}
t0 = time.time()
names = set()
while time.time() - t0 < 15:
    rclpy.spin_once(node, timeout_sec=0.1)
    names = set(node.get_node_names_and_namespaces())
    if want <= names:
        break
time.sleep(0.5)
rclpy.spin_once(node, timeout_sec=0.1)
print(json.dumps({"nodes": sorted(names), "topics": dict(node.get_topic_names_and_types())}))

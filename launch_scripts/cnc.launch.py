"""ROS 2 launch file: the simulator node and the controller node.

    ros2 launch launch_scripts/cnc.launch.py machine:=lathe namespace:=/cnc sim_namespace:=/sim
    ros2 launch launch_scripts/cnc.launch.py cpu_affinity:=1     # both nodes on CPU 1

The binaries are plain executables (pure-Rust DDS, no ament package); they
are taken from CNC_BIN_DIR (default: target/release beside this file's
folder). ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE apply as usual.
"""
import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.substitutions import LaunchConfiguration

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.realpath(__file__)), ".."))
BIN = os.environ.get("CNC_BIN_DIR", os.path.join(ROOT, "target", "release"))


def generate_launch_description():
    machine = LaunchConfiguration("machine")
    ns = LaunchConfiguration("namespace")
    sim_ns = LaunchConfiguration("sim_namespace")
    cpus = ["cpu_affinity:=", LaunchConfiguration("cpu_affinity")]
    return LaunchDescription([
        DeclareLaunchArgument("machine", default_value="mill", description="mill, lathe or a machine file"),
        DeclareLaunchArgument("namespace", default_value="/cnc"),
        DeclareLaunchArgument("sim_namespace", default_value="/sim"),
        DeclareLaunchArgument("cpu_affinity", default_value="[]",
                              description="the CPUs both nodes run on, e.g. 1 or [0,1]; []: any"),
        ExecuteProcess(
            cmd=[os.path.join(BIN, "sim_axes"), "--machine", machine, "--namespace", sim_ns,
                 "--controller-namespace", ns, "--ros-args", "-p", cpus],
            cwd=ROOT, output="screen"),
        ExecuteProcess(
            cmd=[os.path.join(BIN, "cnc_node"), "--machine", machine, "--namespace", ns,
                 "--sim-namespace", sim_ns, "--ros-args", "-p", cpus],
            cwd=ROOT, output="screen"),
    ])

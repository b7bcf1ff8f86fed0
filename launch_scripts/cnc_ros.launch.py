"""ROS 2 launch file with launch_ros: the simulator and the controller as the
nodes of the ament package `cnc_controller`, with namespaces and parameters.

    ros2 launch launch_scripts/cnc_ros.launch.py machine:=lathe namespace:=/cnc sim_namespace:=/sim \
        params_file:=config/cnc_params.yaml
    ros2 launch cnc_controller cnc_ros.launch.py            # the same, found through the package

Needs the package on AMENT_PREFIX_PATH (scripts/ros_peer/install_package.sh;
scripts/ros_peer/setup.sh installs it into .venv-ros, and `. .venv-ros/env.sh`
puts it on the path). `params_file` (default: the package's
config/cnc_params.yaml) holds both nodes' parameters (`/**/cnc_node:` and
`/**/sim_axes:` sections); `machine` and the namespaces given here win over it.
Every option of the nodes is a parameter of the same name (docs/ros_interface.md §6.2).
ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE apply as usual.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import EqualsSubstitution, LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

PKG = "cnc_controller"


def generate_launch_description():
    machine = LaunchConfiguration("machine")
    ns = LaunchConfiguration("namespace")
    sim_ns = LaunchConfiguration("sim_namespace")
    params = LaunchConfiguration("params_file")
    return LaunchDescription([
        DeclareLaunchArgument("machine", default_value="mill", description="mill, lathe or a machine file"),
        DeclareLaunchArgument("namespace", default_value="/cnc", description="the controller's namespace"),
        DeclareLaunchArgument("sim_namespace", default_value="/sim", description="the simulator's namespace"),
        DeclareLaunchArgument(
            "params_file",
            default_value=PathJoinSubstitution([FindPackageShare(PKG), "config", "cnc_params.yaml"]),
            description="parameters of both nodes (rcl's YAML)"),
        DeclareLaunchArgument(
            "cpu_affinity", default_value="",
            description="the CPUs both nodes run on, e.g. [1] (a twin on one CPU costs less); "
                        "empty: the params file's, else any"),
    ] + nodes(machine, ns, sim_ns, params))


def nodes(machine, ns, sim_ns, params):
    """Both nodes, twice: with `cpu_affinity` where the launch argument
    gives it, else without (so that the params file's stands)."""
    cpus = LaunchConfiguration("cpu_affinity")
    out = []
    for given in (False, True):
        extra = {"cpu_affinity": cpus} if given else {}
        cond = (UnlessCondition if given else IfCondition)(EqualsSubstitution(cpus, ""))
        out += [
            Node(package=PKG, executable="sim_axes", name="sim_axes", namespace=sim_ns, output="screen",
                 parameters=[params, {"machine": machine, "controller_namespace": ns, **extra}],
                 condition=cond),
            Node(package=PKG, executable="cnc_node", name="cnc_node", namespace=ns, output="screen",
                 parameters=[params, {"machine": machine, "sim_namespace": sim_ns, **extra}],
                 condition=cond),
        ]
    return out

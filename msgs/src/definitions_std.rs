//! The ROS 2 definitions (`.msg` text, byte for byte as installed in
//! `share/<package>/msg/` of ROS 2 Kilted: common_interfaces 5.5.1,
//! rcl_interfaces 2.3.0, geometry2) of the standard message types that the
//! controller publishes or records. Recordings store them as schema text
//! (see [`crate::schema`]), exactly as rosbag2 reads them from the share
//! directories.

/// `builtin_interfaces/msg/Time` (`builtin_interfaces/msg/Time.msg`)
pub const TIME_MSG: &str = r#"# This message communicates ROS Time defined here:
# https://design.ros2.org/articles/clock_and_time.html

# The seconds component, valid over all int32 values.
int32 sec

# The nanoseconds component, valid in the range [0, 1e9).
uint32 nanosec
"#;

/// `std_msgs/msg/Header` (`std_msgs/msg/Header.msg`)
pub const HEADER_MSG: &str = r#"# Standard metadata for higher-level stamped data types.
# This is generally used to communicate timestamped data
# in a particular coordinate frame.

# Two-integer timestamp that is expressed as seconds and nanoseconds.
builtin_interfaces/Time stamp

# Transform frame with which this data is associated.
string frame_id
"#;

/// `std_msgs/msg/Float64` (`std_msgs/msg/Float64.msg`)
pub const FLOAT64_MSG: &str = r#"# This was originally provided as an example message.
# It is deprecated as of Foxy
# It is recommended to create your own semantically meaningful message.
# However if you would like to continue using this please use the equivalent in example_msgs.

float64 data
"#;

/// `std_msgs/msg/String` (`std_msgs/msg/String.msg`)
pub const STRING_MSG: &str = r#"# This was originally provided as an example message.
# It is deprecated as of Foxy
# It is recommended to create your own semantically meaningful message.
# However if you would like to continue using this please use the equivalent in example_msgs.

string data
"#;

/// `sensor_msgs/msg/JointState` (`sensor_msgs/msg/JointState.msg`)
pub const JOINT_STATE_MSG: &str = r#"# This is a message that holds data to describe the state of a set of torque controlled joints.
#
# The state of each joint (revolute or prismatic) is defined by:
#  * the position of the joint (rad or m),
#  * the velocity of the joint (rad/s or m/s) and
#  * the effort that is applied in the joint (Nm or N).
#
# Each joint is uniquely identified by its name
# The header specifies the time at which the joint states were recorded. All the joint states
# in one message have to be recorded at the same time.
#
# This message consists of a multiple arrays, one for each part of the joint state.
# The goal is to make each of the fields optional. When e.g. your joints have no
# effort associated with them, you can leave the effort array empty.
#
# All arrays in this message should have the same size, or be empty.
# This is the only way to uniquely associate the joint name with the correct
# states.

std_msgs/Header header

string[] name
float64[] position
float64[] velocity
float64[] effort
"#;

/// `geometry_msgs/msg/Vector3` (`geometry_msgs/msg/Vector3.msg`)
pub const VECTOR3_MSG: &str = r#"# This represents a vector in free space.

# This is semantically different than a point.
# A vector is always anchored at the origin.
# When a transform is applied to a vector, only the rotational component is applied.

float64 x
float64 y
float64 z
"#;

/// `geometry_msgs/msg/Quaternion` (`geometry_msgs/msg/Quaternion.msg`)
pub const QUATERNION_MSG: &str = r#"# This represents an orientation in free space in quaternion form.

float64 x 0
float64 y 0
float64 z 0
float64 w 1
"#;

/// `geometry_msgs/msg/Transform` (`geometry_msgs/msg/Transform.msg`)
pub const TRANSFORM_MSG: &str = r#"# This represents the transform between two coordinate frames in free space.

Vector3 translation
Quaternion rotation
"#;

/// `geometry_msgs/msg/TransformStamped` (`geometry_msgs/msg/TransformStamped.msg`)
pub const TRANSFORM_STAMPED_MSG: &str = r#"# This expresses a transform from coordinate frame header.frame_id
# to the coordinate frame child_frame_id at the time of header.stamp
#
# This message is mostly used by the
# <a href="https://docs.ros.org/en/rolling/p/tf2/">tf2</a> package.
# See its documentation for more information.
#
# The child_frame_id is necessary in addition to the frame_id
# in the Header to communicate the full reference for the transform
# in a self contained message.

# The frame id in the header is used as the reference frame of this transform.
std_msgs/Header header

# The frame id of the child frame to which this transform points.
string child_frame_id

# Translation and rotation in 3-dimensions of child_frame_id from header.frame_id.
Transform transform
"#;

/// `geometry_msgs/msg/Point` (`geometry_msgs/msg/Point.msg`)
pub const POINT_MSG: &str = r#"# This contains the position of a point in free space
float64 x
float64 y
float64 z
"#;

/// `geometry_msgs/msg/Pose` (`geometry_msgs/msg/Pose.msg`)
pub const POSE_MSG: &str = r#"# A representation of pose in free space, composed of position and orientation.

Point position
Quaternion orientation
"#;

/// `geometry_msgs/msg/PoseStamped` (`geometry_msgs/msg/PoseStamped.msg`)
pub const POSE_STAMPED_MSG: &str = r#"# A Pose with reference coordinate frame and timestamp

std_msgs/Header header
Pose pose
"#;

/// `tf2_msgs/msg/TFMessage` (`tf2_msgs/msg/TFMessage.msg`)
pub const TF_MESSAGE_MSG: &str = r#"geometry_msgs/TransformStamped[] transforms
"#;

/// `sensor_msgs/msg/PointCloud2` (`sensor_msgs/msg/PointCloud2.msg`)
pub const POINT_CLOUD2_MSG: &str = r#"# This message holds a collection of N-dimensional points, which may
# contain additional information such as normals, intensity, etc. The
# point data is stored as a binary blob, its layout described by the
# contents of the "fields" array.
#
# The point cloud data may be organized 2d (image-like) or 1d (unordered).
# Point clouds organized as 2d images may be produced by camera depth sensors
# such as stereo or time-of-flight.

# Time of sensor data acquisition, and the coordinate frame ID (for 3d points).
std_msgs/Header header

# 2D structure of the point cloud. If the cloud is unordered, height is
# 1 and width is the length of the point cloud.
uint32 height
uint32 width

# Describes the channels and their layout in the binary data blob.
PointField[] fields

bool    is_bigendian # Is this data bigendian?
uint32  point_step   # Length of a point in bytes
uint32  row_step     # Length of a row in bytes
uint8[] data         # Actual point data, size is (row_step*height)

bool is_dense        # True if there are no invalid points
"#;

/// `sensor_msgs/msg/PointField` (`sensor_msgs/msg/PointField.msg`)
pub const POINT_FIELD_MSG: &str = r#"# This message holds the description of one point entry in the
# PointCloud2 message format.
uint8 INT8    = 1
uint8 UINT8   = 2
uint8 INT16   = 3
uint8 UINT16  = 4
uint8 INT32   = 5
uint8 UINT32  = 6
uint8 FLOAT32 = 7
uint8 FLOAT64 = 8

# Common PointField names are x, y, z, intensity, rgb, rgba
string name      # Name of field
uint32 offset    # Offset from start of point struct
uint8  datatype  # Datatype enumeration, see above
uint32 count     # How many elements in the field
"#;

/// `rcl_interfaces/msg/Log` (`rcl_interfaces/msg/Log.msg`)
pub const LOG_MSG: &str = r#"##
## Severity level constants
## 
## These logging levels follow the Python Standard
## https://docs.python.org/3/library/logging.html#logging-levels
## And are implemented in rcutils as well
## https://github.com/ros2/rcutils/blob/35f29850064e0c33a4063cbc947ebbfeada11dba/include/rcutils/logging.h#L164-L172
## This leaves space for other standard logging levels to be inserted in the middle in the future,
## as well as custom user defined levels.
## Since there are several other logging enumeration standard for different implementations,
## other logging implementations may need to provide level mappings to match their internal implementations.
##

# Debug is for pedantic information, which is useful when debugging issues.
uint8 DEBUG=10

# Info is the standard informational level and is used to report expected
# information.
uint8 INFO=20

# Warning is for information that may potentially cause issues or possibly unexpected
# behavior.
uint8 WARN=30

# Error is for information that this node cannot resolve.
uint8 ERROR=40

# Information about a impending node shutdown.
uint8 FATAL=50

##
## Fields
##

# Timestamp when this message was generated by the node.
builtin_interfaces/Time stamp

# Corresponding log level, see above definitions.
uint8 level

# The name representing the logger this message came from.
string name

# The full log message.
string msg

# The file the message came from.
string file

# The function the message came from.
string function

# The line in the file the message came from.
uint32 line
"#;

/// `diagnostic_msgs/msg/DiagnosticArray` (`diagnostic_msgs/msg/DiagnosticArray.msg`)
pub const DIAGNOSTIC_ARRAY_MSG: &str = r#"# This message is used to send diagnostic information about the state of the robot.
std_msgs/Header header # for timestamp
DiagnosticStatus[] status # an array of components being reported on
"#;

/// `diagnostic_msgs/msg/DiagnosticStatus` (`diagnostic_msgs/msg/DiagnosticStatus.msg`)
pub const DIAGNOSTIC_STATUS_MSG: &str = r#"# This message holds the status of an individual component of the robot.

# Possible levels of operations.
byte OK=0
byte WARN=1
byte ERROR=2
byte STALE=3

# Level of operation enumerated above.
byte level
# A description of the test/component reporting.
string name
# A description of the status.
string message
# A hardware unique string.
string hardware_id
# An array of values associated with the status.
KeyValue[] values

"#;

/// `diagnostic_msgs/msg/KeyValue` (`diagnostic_msgs/msg/KeyValue.msg`)
pub const KEY_VALUE_MSG: &str = r#"# What to label this value when viewing.
string key
# A value to track over time.
string value
"#;

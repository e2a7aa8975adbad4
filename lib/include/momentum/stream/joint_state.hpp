#pragma once
// sensor_msgs/msg/JointState as ROS 2 serializes it: CDR (XCDR1, the encoding of ROS 2's
// DDS middlewares and of rosbag2), little- or big-endian as its encapsulation header says.
// Used by the MCAP reader (mcap.hpp, mo-log(5)) to turn a bag's joint states into stream rows.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace momentum::stream::ros2 {

// The ROS 2 type name of the message, as a rosbag2 Schema record names it.
inline constexpr std::string_view kJointStateType = "sensor_msgs/msg/JointState";

// The fields of a JointState message (std_msgs/Header header; string[] name; float64[]
// position, velocity, effort). By ROS convention position is rad (m for a prismatic joint),
// velocity rad/s (m/s), effort Nm (N); velocity and effort may be empty, else they have one
// entry per name.
struct JointState {
  std::int32_t stamp_sec = 0;       // header.stamp.sec, s
  std::uint32_t stamp_nanosec = 0;  // header.stamp.nanosec, ns (below 1e9 when well formed)
  std::string frame_id;             // header.frame_id
  std::vector<std::string> name;
  std::vector<double> position;
  std::vector<double> velocity;
  std::vector<double> effort;
};

// Decodes one serialized message (the 4-byte encapsulation header first: 00 01 for
// little-endian CDR, 00 00 for big-endian) into `out`, whose vectors are reused (no
// allocation once they are large enough). Returns an empty string, or why the bytes are not a
// JointState: another encapsulation (XCDR2, parameter lists), a field or sequence that runs past
// the end, a string without its terminating NUL, a sequence count larger than the bytes left
// could hold. Bytes after the last field (alignment padding) are allowed. On failure `out` is
// unspecified.
std::string decode_joint_state(std::string_view bytes, JointState& out);

}  // namespace momentum::stream::ros2

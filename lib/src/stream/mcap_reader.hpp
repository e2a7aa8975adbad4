#pragma once
// The third encoding of Reader::open: a ROS 2 bag in MCAP (mo-log(5), "MCAP"). Internal to the
// stream stage: reader.cpp dispatches here when the input starts with the MCAP magic.

#include <memory>
#include <string>

#include "momentum/stream/mcap.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::stream::detail {

// Reads the bag from `input` (positioned at its first byte) up to the first usable
// sensor_msgs/msg/JointState message of the chosen topic, which fixes the columns (t, q<j>,
// dq<j> when the message has velocities, tau_m<j> when it has efforts). Throws momentum::Error
// (`name: ...`) when the bag has no such topic, several of them and options.topic is empty,
// options.topic names a topic of another type or encoding, or a joint of options.joint_names
// is not in the first message. `seekable_path`, when not empty, is the input's path as a regular
// file: its summary is read first, so that a topic error comes before any row.
std::unique_ptr<Reader> open_mcap(std::unique_ptr<mcap::ByteSource> input, const std::string& name,
                                  const ReaderOptions& options, const std::string& seekable_path);

}  // namespace momentum::stream::detail

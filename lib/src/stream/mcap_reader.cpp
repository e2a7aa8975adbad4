#include "mcap_reader.hpp"

#include <algorithm>
#include <set>
#include <unordered_map>

#include "momentum/core/error.hpp"
#include "momentum/core/text.hpp"
#include "momentum/stream/columns.hpp"
#include "momentum/stream/joint_state.hpp"

namespace momentum::stream::detail {

namespace {

using core::printable;
using Item = mcap::RecordReader::Item;

// A row's position packs the byte offset of its record (or of the chunk holding it) above the
// record's number inside the chunk, so that positions grow through the file and each row has
// its own. Offsets up to 2^40 bytes (1 TiB) and 2^24 records a chunk (a 64 MiB chunk holds at
// most 2.2 million 31-byte message records) fit.
constexpr int kRecordBits = 24;

std::string name_list(const std::vector<std::string>& names) {
  std::string out;
  const std::size_t shown = std::min<std::size_t>(names.size(), 12);
  for (std::size_t i = 0; i < shown; ++i) out += (i ? ", " : "") + printable(names[i]);
  if (names.size() > shown) out += ", ... (" + std::to_string(names.size()) + " names)";
  return out.empty() ? "no names" : out;
}

class McapReader final : public Reader {
 public:
  McapReader(std::unique_ptr<mcap::ByteSource> input, const std::string& name, const ReaderOptions& options,
             const std::string& seekable_path)
      : in_(std::move(input)) {
    name_ = name;
    strict_ = options.strict;
    encoding_ = Encoding::mcap;
    before_read_ = options.before_read;
    in_->before_read = &before_read_;
    topic_ = options.topic;
    chain_ = options.joint_names;
    records_ = std::make_unique<mcap::RecordReader>(*in_, name_);
    if (!seekable_path.empty()) check_summary(mcap::summary_channels(seekable_path));
    if (!next_message_row()) throw Error(no_topic_message());
    first_position_ = raw_position_;
    first_pending_ = true;
  }

  const double* read_row() override {
    if (first_pending_) {
      first_pending_ = false;
      raw_position_ = first_position_;
      ++rows_read_;
      return row_.data();
    }
    if (!next_message_row()) return nullptr;
    ++rows_read_;
    return row_.data();
  }

  // Reads records up to the next message of the selected topic that fills row_ (the columns
  // set from the first one); damage is reported and skipped, channels are considered on the
  // way. False at the end of the bag.
  bool next_message_row() {
    for (;;) {
      const Item item = records_->next();
      if (item == Item::end) return false;
      if (item == Item::damage) {
        raw_position_ = record_position();
        skip_bad(records_->damage_kind(), records_->damage());
        continue;
      }
      if (item == Item::channel) {
        consider(records_->channel());
        continue;
      }
      if (!selected(records_->message().channel_id) || !decode()) continue;
      if (columns_.empty() && !set_columns()) continue;
      if (fill_row()) return true;
    }
  }

  std::string location(std::uint64_t position) const override {
    const std::uint64_t record = position & ((std::uint64_t{1} << kRecordBits) - 1);
    std::string text = name() + ": byte " + std::to_string(position >> kRecordBits);
    if (record != 0) text += ", chunk record " + std::to_string(record);
    return text;
  }

 private:
  std::uint64_t record_position() const {
    return (records_->record_offset() << kRecordBits) | std::min<std::uint64_t>(records_->chunk_record(), (1u << kRecordBits) - 1);
  }

  // The topics the bag's summary lists: a topic error before any row is read.
  void check_summary(const std::vector<mcap::Channel>& channels) {
    if (channels.empty()) return;
    std::vector<std::string> joint_topics, topics;
    for (const mcap::Channel& channel : channels) {
      topics.push_back(channel.topic + " (" + (channel.schema_name.empty() ? "no schema" : channel.schema_name) + ")");
      if (channel.schema_name == ros2::kJointStateType &&
          std::find(joint_topics.begin(), joint_topics.end(), channel.topic) == joint_topics.end())
        joint_topics.push_back(channel.topic);
    }
    if (!topic_.empty()) {
      if (std::none_of(channels.begin(), channels.end(), [&](const mcap::Channel& c) { return c.topic == topic_; }))
        throw Error(name() + ": no topic '" + printable(topic_) + "' (topics: " + name_list(topics) + ")");
      return;
    }
    if (joint_topics.size() > 1) {
      joint_topics_ = joint_topics;
      throw Error(several_topics_message());
    }
  }

  // A new channel: the chosen topic's, a JointState topic to choose among, or another.
  void consider(const mcap::Channel& channel) {
    const bool joint_state = channel.schema_name == ros2::kJointStateType;
    if (!topic_.empty()) {
      if (channel.topic != topic_) return;
      if (!joint_state)
        throw Error(name() + ": topic '" + printable(topic_) + "' carries " +
                    (channel.schema_name.empty() ? std::string("messages without a schema") : "'" + printable(channel.schema_name) + "'") +
                    ", not " + std::string(ros2::kJointStateType));
      check_encoding(channel);
      selected_.insert(channel.id);
      return;
    }
    if (!joint_state) return;
    if (std::find(joint_topics_.begin(), joint_topics_.end(), channel.topic) == joint_topics_.end())
      joint_topics_.push_back(channel.topic);
    if (joint_topics_.size() > 1) throw Error(several_topics_message());
    check_encoding(channel);
    selected_.insert(channel.id);
  }
  void check_encoding(const mcap::Channel& channel) const {
    if (channel.message_encoding != "cdr")
      throw Error(name() + ": topic '" + printable(channel.topic) + "': message encoding '" +
                  printable(channel.message_encoding) + "' (this reader decodes cdr, the encoding of ROS 2)");
  }
  std::string several_topics_message() const {
    return name() + ": several " + std::string(ros2::kJointStateType) + " topics (" + name_list(joint_topics_) +
           "): choose one with --topic";
  }
  std::string no_topic_message() const {
    std::vector<std::string> topics;
    for (const auto& [id, channel] : records_->channels())
      topics.push_back(channel.topic + " (" + (channel.schema_name.empty() ? "no schema" : channel.schema_name) + ")");
    const std::string seen = topics.empty() ? "the bag has no topics" : "topics: " + name_list(topics);
    if (!topic_.empty() && selected_.empty()) return name() + ": no topic '" + printable(topic_) + "' (" + seen + ")";
    if (selected_.empty()) return name() + ": no " + std::string(ros2::kJointStateType) + " topic (" + seen + ")";
    return name() + ": no readable " + std::string(ros2::kJointStateType) + " message on " +
           (topic_.empty() ? "'" + printable(joint_topics_.front()) + "'" : "'" + printable(topic_) + "'");
  }
  bool selected(std::uint16_t channel) const { return selected_.count(channel) != 0; }

  // Decodes the current message into state_; a bad one is skipped as a bad row.
  bool decode() {
    raw_position_ = record_position();
    const std::string why = ros2::decode_joint_state(records_->message().data, state_);
    if (why.empty()) return true;
    skip_bad("bad message", "bad " + std::string(ros2::kJointStateType) + " message: " + why);
    return false;
  }

  // Fixes the columns from the first decoded message: the chain's joints in chain order, or
  // the message's own order without a chain.
  bool set_columns() {
    if (state_.name.empty()) {
      skip_bad("bad message", "a JointState message without joint names");
      return false;
    }
    if (auto twice = first_duplicate(state_.name)) {
      skip_bad("bad message", "joint '" + printable(*twice) + "' named twice");
      return false;
    }
    if (!chain_.empty()) {
      for (const std::string& joint : chain_)
        if (std::find(state_.name.begin(), state_.name.end(), joint) == state_.name.end())
          throw Error(location(raw_position_) + ": joint '" + printable(joint) +
                      "' of the profile's chain is not in the JointState message (it has " + name_list(state_.name) + ")");
      joints_ = chain_;
    } else {
      joints_ = state_.name;
    }
    has_velocity_ = !state_.velocity.empty();
    has_effort_ = !state_.effort.empty();
    const std::size_t n = joints_.size();
    columns_.push_back("t");
    for (const auto& prefix : {"q", "dq", "tau_m"}) {
      if ((prefix == std::string("dq") && !has_velocity_) || (prefix == std::string("tau_m") && !has_effort_)) continue;
      for (const std::string& column : joint_columns(prefix, n)) columns_.push_back(column);
    }
    const mcap::Channel* channel = records_->find_channel(records_->message().channel_id);
    leading_comments_.push_back(" ros2 bag: topic " + (channel ? channel->topic : std::string("?")) + " (" +
                                std::string(ros2::kJointStateType) + ")" + (has_velocity_ ? "" : ", no velocities") +
                                (has_effort_ ? ", effort as tau_m" : ", no efforts"));
    std::string joints = " joints:";
    for (std::size_t j = 0; j < n; ++j) joints += " " + std::to_string(j + 1) + "=" + joints_[j];
    leading_comments_.push_back(joints);
    row_.resize(columns_.size());
    return true;
  }

  // The row of the current message: its joints put in column order by name.
  bool fill_row() {
    const ros2::JointState& s = state_;
    const std::size_t n = joints_.size(), names = s.name.size();
    if (s.position.size() != names) {
      skip_bad("bad message", std::to_string(s.position.size()) + " positions for " + std::to_string(names) + " joint names");
      return false;
    }
    if (has_velocity_ && s.velocity.size() != names) {
      skip_bad("bad message", std::to_string(s.velocity.size()) + " velocities for " + std::to_string(names) + " joint names");
      return false;
    }
    if (has_effort_ && s.effort.size() != names) {
      skip_bad("bad message", std::to_string(s.effort.size()) + " efforts for " + std::to_string(names) + " joint names");
      return false;
    }
    if (s.name != order_names_ && !map_names()) return false;
    const mcap::Message& message = records_->message();
    if (s.stamp_sec == 0 && s.stamp_nanosec == 0) {
      if (!warned_stamp_) {
        warned_stamp_ = true;
        warn(location(raw_position_) + ": header.stamp is zero: t is the message's log_time (the recorder's clock), "
                                       "here and in every message stamped zero");
      }
      row_[0] = static_cast<double>(message.log_time) * 1e-9;
    } else {
      row_[0] = static_cast<double>(s.stamp_sec) + static_cast<double>(s.stamp_nanosec) * 1e-9;
    }
    std::size_t column = 1;
    for (std::size_t j = 0; j < n; ++j) row_[column++] = s.position[order_[j]];
    if (has_velocity_)
      for (std::size_t j = 0; j < n; ++j) row_[column++] = s.velocity[order_[j]];
    if (has_effort_)
      for (std::size_t j = 0; j < n; ++j) row_[column++] = s.effort[order_[j]];
    return true;
  }

  // order_[j]: the index in the message of joint j; kept while messages keep the same names.
  bool map_names() {
    const std::vector<std::string>& names = state_.name;
    std::unordered_map<std::string_view, std::size_t> index;
    index.reserve(names.size());
    for (std::size_t i = 0; i < names.size(); ++i)
      if (!index.emplace(names[i], i).second) {
        skip_bad("bad message", "joint '" + printable(names[i]) + "' named twice");
        return false;
      }
    std::vector<std::size_t> order(joints_.size());
    for (std::size_t j = 0; j < joints_.size(); ++j) {
      auto it = index.find(joints_[j]);
      if (it == index.end()) {
        skip_bad("missing joint", "joint '" + printable(joints_[j]) + "' is not in the message (it has " + name_list(names) + ")");
        return false;
      }
      order[j] = it->second;
      index.erase(it);
    }
    if (!index.empty() && !noted_extra_) {
      noted_extra_ = true;
      std::vector<std::string> extra;
      for (const std::string& joint : names)
        if (std::find(joints_.begin(), joints_.end(), joint) == joints_.end()) extra.push_back(joint);
      warn(location(raw_position_) + ": joints not in " + (chain_.empty() ? "the first message" : "the profile's chain") +
           " left out: " + name_list(extra));
    }
    order_ = std::move(order);
    order_names_ = names;
    return true;
  }

  std::unique_ptr<mcap::ByteSource> in_;
  std::unique_ptr<mcap::RecordReader> records_;
  std::string topic_;
  std::vector<std::string> chain_;         // the profile's joint names, root to tip (may be empty)
  std::vector<std::string> joint_topics_;  // JointState topics seen (topic_ empty)
  std::set<std::uint16_t> selected_;       // channels of the chosen topic
  ros2::JointState state_;
  std::vector<std::string> joints_;       // the columns' joints, in column order
  std::vector<std::string> order_names_;  // the names order_ was made for
  std::vector<std::size_t> order_;
  std::vector<double> row_;
  bool has_velocity_ = false, has_effort_ = false;
  bool warned_stamp_ = false, noted_extra_ = false;
  bool first_pending_ = false;
  std::uint64_t first_position_ = 0;
};

}  // namespace

std::unique_ptr<Reader> open_mcap(std::unique_ptr<mcap::ByteSource> input, const std::string& name,
                                  const ReaderOptions& options, const std::string& seekable_path) {
  return std::make_unique<McapReader>(std::move(input), name, options, seekable_path);
}

}  // namespace momentum::stream::detail

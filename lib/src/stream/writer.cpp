#include "momentum/stream/writer.hpp"

#include <cstring>
#include <limits>

#include "momentum/core/error.hpp"

namespace momentum::stream {

namespace {
constexpr std::size_t kBufferSize = 256 * 1024;
// Room for the longest formatted double plus its separator.
constexpr std::size_t kMaxNumber = 32;

void put_u32(std::vector<char>& out, std::uint32_t v) {
  char bytes[4];
  std::memcpy(bytes, &v, 4);
  out.insert(out.end(), bytes, bytes + 4);
}
void put_string(std::vector<char>& out, std::string_view s) {
  put_u32(out, static_cast<std::uint32_t>(s.size()));
  out.insert(out.end(), s.begin(), s.end());
}
}  // namespace

std::unique_ptr<Writer> Writer::open(const std::string& path, WriterOptions options) {
  if (options.encoding == Encoding::mcap) throw Error("streams are written as csv or bin, not mcap");
  // The output first: a path that cannot be opened throws before there is a Writer to close.
  auto out = std::make_unique<core::OutputFile>(path);
  std::unique_ptr<Writer> writer(new Writer());
  writer->out_ = std::move(out);
  writer->options_ = options;
  writer->buffer_.resize(kBufferSize);
  return writer;
}

Writer::~Writer() {
  try {
    close();
  } catch (...) {
  }
}

void Writer::comment(std::string_view text) {
  if (!header_written_) {
    pending_comments_.emplace_back(text);
    return;
  }
  if (options_.encoding == Encoding::csv) {
    const std::string lines = csv_comment_lines(text);  // a line break cannot start a row
    append(lines.data(), lines.size());
  } else {
    std::uint64_t marker = kCommentRecordBits, length = text.size();
    append(&marker, 8);
    append(&length, 8);
    append(text.data(), text.size());
    static constexpr char zeros[8] = {};
    append(zeros, (8 - text.size() % 8) % 8);
  }
  if (options_.line_buffered) flush();
}

void Writer::header(const std::vector<std::string>& columns) {
  if (header_written_) throw Error(out_->name() + ": header written twice");
  header_written_ = true;
  width_ = columns.size();
  std::vector<char> out;
  if (options_.encoding == Encoding::csv) {
    std::string text;
    for (const auto& c : pending_comments_) text += csv_comment_lines(c);
    try {
      text += csv_header_line(columns);  // quoted or refused: a name cannot split the header
    } catch (const Error& e) {
      throw Error(out_->name() + ": " + e.what());
    }
    out.assign(text.begin(), text.end());
  } else {
    out.insert(out.end(), kBinaryMagic, kBinaryMagic + sizeof kBinaryMagic);
    put_u32(out, kBinaryVersion);
    put_u32(out, static_cast<std::uint32_t>(columns.size()));
    put_u32(out, static_cast<std::uint32_t>(pending_comments_.size()));
    for (const auto& c : pending_comments_) put_string(out, c);
    for (const auto& c : columns) put_string(out, c);
  }
  pending_comments_.clear();
  append(out.data(), out.size());
  if (options_.line_buffered) flush();
}

void Writer::row(const double* values) {
  if (options_.encoding == Encoding::binary) {
    std::size_t bytes = width_ * sizeof(double);
    if (bytes > 0) {
      std::uint64_t first;
      std::memcpy(&first, values, 8);
      append(values, bytes);
      if (first == kCommentRecordBits) {
        // A NaN carrying our marker payload would read back as a comment; write the canonical NaN.
        double nan = std::numeric_limits<double>::quiet_NaN();
        std::memcpy(buffer_.data() + used_ - bytes, &nan, 8);
      }
    }
  } else {
    if (buffer_.size() - used_ < width_ * kMaxNumber + 1) {
      flush();
      if (buffer_.size() < width_ * kMaxNumber + 1) buffer_.resize(width_ * kMaxNumber + 1);
    }
    char* out = buffer_.data() + used_;
    char* start = out;
    for (std::size_t i = 0; i < width_; ++i) {
      if (i) *out++ = ',';
      out += format_double(values[i], out);
    }
    *out++ = '\n';
    used_ += static_cast<std::size_t>(out - start);
  }
  ++rows_written_;
  if (options_.line_buffered) flush();
}

void Writer::append(const void* data, std::size_t size) {
  if (buffer_.size() - used_ < size) {
    flush();
    if (size > buffer_.size()) {
      write_all(static_cast<const char*>(data), size);
      return;
    }
  }
  std::memcpy(buffer_.data() + used_, data, size);
  used_ += size;
}

void Writer::flush() {
  if (used_ == 0) return;
  std::size_t n = used_;
  used_ = 0;
  write_all(buffer_.data(), n);
}

void Writer::write_all(const char* data, std::size_t size) { out_->write(std::string_view(data, size)); }

void Writer::close() {
  if (closed_ || !out_) return;
  if (!header_written_ && !pending_comments_.empty()) {
    // Nothing but comments: still a readable stream of no columns is impossible, so emit them
    // as CSV comment lines; a binary stream needs a header, which we do not have.
    if (options_.encoding == Encoding::csv) {
      for (const auto& c : pending_comments_) {
        const std::string lines = csv_comment_lines(c);
        append(lines.data(), lines.size());
      }
    }
    pending_comments_.clear();
  }
  closed_ = true;
  try {
    flush();
  } catch (...) {
    try {
      out_->close();
    } catch (...) {
    }
    throw;
  }
  out_->close();
}

}  // namespace momentum::stream

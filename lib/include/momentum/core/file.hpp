#pragma once
// Where every tool's output goes, by one policy: the name "-" (or none) is standard output; a
// reader that went away (a closed pipe) ends the run quietly (BrokenPipe); a write that fails
// (a full disk, an I/O error) is an error naming the file; a whole document written to a file
// replaces it atomically (the profile updates of mo-calibrate, mo-lugre-fit and mo-dynfit,
// reports). The caller builds the bytes; this layer decides where they go, so it composes with
// any serialisation.

#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace momentum::core {

// Thrown when the reader of our output went away (EPIPE). Tools end quietly with status 0.
class BrokenPipe : public std::exception {
 public:
  const char* what() const noexcept override { return "broken pipe"; }
};

// True for the names that mean standard output: "-" and "".
inline bool is_standard_output(std::string_view path) { return path.empty() || path == "-"; }

// Writes all of `bytes` to the descriptor `fd` (short writes and EINTR retried). Throws
// BrokenPipe on EPIPE, and momentum::Error `NAME: write error: why` on any other failure (a
// full disk: `No space left on device`).
void write_all(int fd, std::string_view bytes, std::string_view name);

// A streamed output: standard output for "-" or "" (named "<stdout>" in messages, never
// closed), else the file `path`, created (mode 0666 less the umask) or truncated in place the
// way a shell's `>` does: a symlink is followed, a device or fifo written as it is (-o
// /dev/null stays a device). Writes go straight to write(2): buffer above it.
class OutputFile {
 public:
  // Throws momentum::Error `PATH: cannot create: why`.
  explicit OutputFile(const std::string& path);
  ~OutputFile();  // closes a file, ignoring errors: call close() to see them
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  // write_all to this output.
  void write(std::string_view bytes);
  // Closes a file (standard output stays open); throws momentum::Error `NAME: close error:
  // why` (a full disk that NFS reports late). Further writes are errors.
  void close();

  const std::string& name() const { return name_; }
  int fd() const { return fd_; }
  bool is_standard_output() const { return !owns_fd_; }
  // True when the output is a pipe, socket or terminal (a live pipeline wants each row at once).
  bool interactive() const { return interactive_; }

 private:
  std::string name_;
  int fd_ = -1;
  bool owns_fd_ = false;
  bool interactive_ = false;
};

// The file that writing `path` would change: symlinks are followed (each level, relative
// targets against the link's folder) to the real target. Throws momentum::Error naming `path`
// when a link cannot be read, when the chain of links is longer than 40 (a loop), or when the
// target exists and is not a regular file (a device such as /dev/null, a directory, a fifo):
// `path: not a regular file (a character device); not replaced`.
std::filesystem::path write_target(const std::filesystem::path& path);

struct ReplaceOptions {
  // Refuse a target whose mode has no write permission for its owner (even as root): a
  // read-only profile is meant to stay as it is.
  bool refuse_read_only = true;
  // Mode of a file that did not exist yet (an existing file keeps its own).
  unsigned new_mode = 0644;
};

// Replaces the file `path` names (write_target) by `bytes`: writes them to a temporary file in
// the target's folder, fsyncs it, gives it the old file's mode (ReplaceOptions::new_mode for a
// new file) and renames it over the target, so that readers see the old or the new content,
// never a torn file, and a symlink stays a symlink. The temporary file is removed on every
// failure, and when SIGINT or SIGTERM arrives while it exists (the signal is then delivered as
// before). Throws momentum::Error naming `path` (write errors, a full disk, a read-only target,
// what write_target throws).
void replace_file(const std::filesystem::path& path, std::string_view bytes, const ReplaceOptions& options = {});

// Writes a whole document (a report, a profile, a JSON object) to `path`: to standard output
// for "-" or "" (after what the C and C++ streams hold for it), else by replace_file when
// `path` names a regular file or nothing yet, so that a reader never sees half a document, and
// in place when it names a device or fifo (/dev/null, /dev/stdout). Throws BrokenPipe, or
// momentum::Error naming `path` (what write_all and replace_file throw).
void write_document(const std::string& path, std::string_view bytes, const ReplaceOptions& options = {});

// While alive, removes the file `path` when SIGINT or SIGTERM arrives, then delivers the signal
// to the handler that was there before (the default one ends the process). For temporary files
// that must not outlive an interrupted run. At most 4 at once; paths of 4096 bytes or more are
// not covered.
class RemoveOnSignal {
 public:
  explicit RemoveOnSignal(const std::string& path);
  ~RemoveOnSignal();
  RemoveOnSignal(const RemoveOnSignal&) = delete;
  RemoveOnSignal& operator=(const RemoveOnSignal&) = delete;

 private:
  int slot_ = -1;
};

// An exclusive advisory lock (flock) on the file a path names, for a read-compare-write that
// no concurrent run may interleave with (two updates of one profile). The lock is taken on the
// real target's inode and re-taken when another process renamed a new file over it meanwhile,
// so that after the constructor the path's current content is what the holder reads, and
// nobody else replaces it until the lock is released (destructor, or release()).
class FileLock {
 public:
  // Locks `path`'s target (write_target), waiting while another process holds it (reported
  // once through `waiting`, when given). A target that does not exist yet is not locked
  // (nothing to compare with); locked() says which. Throws momentum::Error naming `path`.
  explicit FileLock(const std::filesystem::path& path,
                    const std::function<void(const std::string& path)>& waiting = nullptr);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

  bool locked() const { return fd_ >= 0; }
  const std::filesystem::path& target() const { return target_; }
  void release();

 private:
  std::filesystem::path target_;
  int fd_ = -1;
};

}  // namespace momentum::core

#pragma once
// Where every tool's input comes from and its output goes, by one policy: the name "-" (or none)
// is standard input or output; a path that cannot be opened is an error naming it; an output
// that is one of the run's inputs (the same file by device and inode, whatever path or symlink
// names it) is refused before anything is truncated; a reader that went away (a closed pipe)
// ends the run quietly (BrokenPipe); a write that fails (a full disk, an I/O error) is an error
// naming the file; a whole document written to a file replaces it atomically (the profile
// updates of mo-calibrate, mo-friction-fit and mo-dynfit, reports), under the profile lock when
// asked. The caller builds the bytes; this layer decides where they go, so it composes with any
// serialisation.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace momentum::core {

// Thrown when the reader of our output went away (EPIPE). Tools end quietly with status 0.
class BrokenPipe : public std::exception {
 public:
  const char* what() const noexcept override { return "broken pipe"; }
};

// True for the names that mean standard output: "-" and "".
inline bool is_standard_output(std::string_view path) { return path.empty() || path == "-"; }

// True for the names that mean standard input: "-" and "".
inline bool is_standard_input(std::string_view path) { return path.empty() || path == "-"; }

// How messages name an input: "<stdin>" for standard input, else its path.
inline std::string input_name(std::string_view path) {
  return is_standard_input(path) ? std::string("<stdin>") : std::string(path);
}

// Writes all of `bytes` to the descriptor `fd` (short writes and EINTR retried). Throws
// BrokenPipe on EPIPE, and momentum::Error `NAME: write error: why` on any other failure (a
// full disk: `No space left on device`).
void write_all(int fd, std::string_view bytes, std::string_view name);

// Opens the file `path` for reading ("-" or "": standard input, returned as it is) and records
// it as an input of this run (when it is a regular file), so that no output of the run may
// truncate or replace it (OutputFile, replace_file). Returns the descriptor (O_CLOEXEC; the
// caller closes a file's). Throws momentum::Error `NAME: cannot open: why`, and `NAME: is also
// the output OUTPUT; not read` when an output of the run is that file; NAME is `display_name`
// when given, else the path ("<stdin>" for standard input).
int open_input(const std::string& path, const std::string& display_name = "");

// Closes a descriptor open_input returned (standard input stays open); the file is no longer
// an input of the run unless expect_input declared it.
void close_input(int fd);

// Records the file `path` names (symlinks followed) as an input the run will read later, so that
// an output opened before the input is refused too (a tool's positional inputs, declared when
// its options are parsed). A path that does not exist, and "-" or "", are ignored. Messages
// name it `display_name` when given, else `path`.
void expect_input(const std::string& path, const std::string& display_name = "");

// Throws momentum::Error `NAME: is also an input (INPUT); not overwritten` when the file `path`
// names (symlinks followed) is an input of this run (open_input, expect_input). NAME is
// `display_name` when given, else the path. Nothing happens when the file does not exist.
void refuse_if_input(const std::string& path, const std::string& display_name = "");

// Forgets the inputs and outputs recorded so far (for tests that run several tools' work in one
// process).
void forget_inputs_and_outputs();

// A streamed output: standard output for "-" or "" (named "<stdout>" in messages, never
// closed), else the file `path`, created (mode 0666 less the umask) or truncated in place the
// way a shell's `>` does: a symlink is followed, a device or fifo written as it is (-o
// /dev/null stays a device). An output that is one of the run's inputs (standard output
// redirected onto an input included) or another output of the run is refused before it is
// truncated. Writes go straight to write(2): buffer above it.
class OutputFile {
 public:
  // Throws momentum::Error `PATH: cannot create: why` (a missing folder, a folder, a read-only
  // file, a symlink loop), `PATH: is also an input (INPUT); not overwritten` and `PATH: is also
  // the output OTHER; not overwritten`.
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
  void forget();  // the output is no longer one of the run's
  std::string name_;
  int fd_ = -1;
  bool owns_fd_ = false;
  bool interactive_ = false;
  bool recorded_ = false;
  std::pair<std::uint64_t, std::uint64_t> id_;  // device and inode
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
  // Hold the target's FileLock while writing (taken here unless this process holds it
  // already): every profile write does, so that it never interleaves with another run's
  // read-compare-write of the same profile.
  bool lock = false;
};

// The name pattern of replace_file's temporary files: "." + the target's file name + ".tmp-"
// and 6 characters (mkstemp's). Each is flocked by its writer for as long as it is written.
std::string temporary_prefix(const std::filesystem::path& target);

// Removes the temporary files of `target` (temporary_prefix) that no live writer holds: what a
// writer killed by SIGKILL or a power cut left behind. Never removes a temporary that another
// process is writing (its writer's flock says so). Returns how many it removed.
int remove_stale_temporaries(const std::filesystem::path& target);

// Replaces the file `path` names (write_target) by `bytes`: writes them to a temporary file in
// the target's folder (temporary_prefix, flocked while written; stale ones of dead writers are
// removed first), fsyncs it, gives it the old file's mode (ReplaceOptions::new_mode for a new
// file) and renames it over the target, so that readers see the old or the new content, never
// a torn file, and a symlink stays a symlink. The temporary file is removed on every failure,
// and when SIGINT, SIGTERM or SIGHUP arrives while it exists (the signal is then delivered as
// before). Throws momentum::Error naming `path` (write errors, a full disk, a read-only target,
// a target that is an input of this run, what write_target and FileLock throw).
void replace_file(const std::filesystem::path& path, std::string_view bytes, const ReplaceOptions& options = {});

// Writes a whole document (a report, a profile, a JSON object) to `path`: to standard output
// for "-" or "" (after what the C and C++ streams hold for it), else by replace_file when
// `path` names a regular file or nothing yet, so that a reader never sees half a document, and
// in place when it names a device or fifo (/dev/null, /dev/stdout). Throws BrokenPipe, or
// momentum::Error naming `path` (what write_all and replace_file throw).
void write_document(const std::string& path, std::string_view bytes, const ReplaceOptions& options = {});

// While alive, removes the file `path` when SIGINT, SIGTERM or SIGHUP arrives, then delivers the signal
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
// nobody else replaces it until the lock is released (destructor, or release()). The holder
// removes the target's stale temporaries (remove_stale_temporaries).
//
// A shell script takes the same lock on the real file (readlink -f), re-taking it while the
// inode it locked is no longer the one the path names:
//   exec 9<"$target"; flock 9; [ "$(stat -L -c %d:%i /dev/fd/9)" = "$(stat -c %d:%i "$target")" ]
// and installs a file with a temporary in the same folder renamed over "$target" (mv -T, no
// -f over a symlink), not named like temporary_prefix unless it flocks it too.
class FileLock {
 public:
  // Locks `path`'s target (write_target), waiting while another process holds it (reported
  // once through `waiting`, when given). A target that does not exist yet is not locked
  // (nothing to compare with); locked() says which. Throws momentum::Error naming `path`.
  // Within one process the locks held are recorded: replace_file with ReplaceOptions::lock
  // does not take a lock this process holds already (it would wait for itself).
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
  std::pair<std::uint64_t, std::uint64_t> id_;  // device and inode locked
};

}  // namespace momentum::core

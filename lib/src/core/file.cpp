#include "momentum/core/file.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <dirent.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <mutex>
#include <vector>

#include "momentum/core/error.hpp"

namespace momentum::core {
namespace fs = std::filesystem;
namespace {

[[noreturn]] void fail(const fs::path& path, const std::string& message) {
  throw Error(path.string() + ": " + message);
}

std::string kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a fifo";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a plain file";
}

// Writes all of `bytes` to `fd`; 0, or the errno of the write that failed.
int write_bytes(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  return 0;
}

// Temporary files that exist right now, removed by the signal handler: fixed storage, so that
// the handler only calls async-signal-safe functions.
constexpr int kSlots = 4;
constexpr std::size_t kPathMax = 4096;
char g_temp[kSlots][kPathMax];
volatile std::sig_atomic_t g_used[kSlots];
// The signals that end a run while it can still run code (SIGKILL cannot be caught: the next
// write removes what it leaves, remove_stale_temporaries).
constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};
struct sigaction g_previous[std::size(kSignals)];
int g_registered = 0;

void restore_handlers() {
  for (std::size_t k = 0; k < std::size(kSignals); ++k) ::sigaction(kSignals[k], &g_previous[k], nullptr);
}

extern "C" void remove_temporaries(int signal) {
  for (int i = 0; i < kSlots; ++i)
    if (g_used[i]) ::unlink(g_temp[i]);
  // Deliver the signal as if this handler had not been there.
  restore_handlers();
  ::raise(signal);
}

// The files of this run: inputs, streamed outputs, and the profile locks this process holds.
struct FileId {
  dev_t dev = 0;
  ino_t ino = 0;
  bool operator==(const FileId& o) const { return dev == o.dev && ino == o.ino; }
};
struct NamedFile {
  FileId id;
  std::string name;
  int open = 0;           // descriptors open on it now
  bool expected = false;  // declared by expect_input: for the whole run
};
std::mutex g_files_mutex;
std::vector<NamedFile> g_inputs, g_outputs;
std::vector<FileId> g_locks_held;

FileId id_of(const struct stat& st) { return {st.st_dev, st.st_ino}; }

const NamedFile* find(const std::vector<NamedFile>& files, const FileId& id) {
  for (const auto& f : files)
    if (f.id == id) return &f;
  return nullptr;
}

// Records one more open descriptor of `id` (or, with `expected`, a file of the whole run).
void record(std::vector<NamedFile>& files, const FileId& id, const std::string& name, bool expected = false) {
  std::lock_guard<std::mutex> guard(g_files_mutex);
  for (auto& f : files) {
    if (f.id == id) {
      if (expected) f.expected = true;
      else ++f.open;
      return;
    }
  }
  files.push_back({id, name, expected ? 0 : 1, expected});
}

// One descriptor of `id` closed: forgotten once none is open and it was not declared.
void unrecord(std::vector<NamedFile>& files, const FileId& id) {
  std::lock_guard<std::mutex> guard(g_files_mutex);
  for (auto it = files.begin(); it != files.end(); ++it) {
    if (!(it->id == id)) continue;
    if (it->open > 0) --it->open;
    if (it->open == 0 && !it->expected) files.erase(it);
    return;
  }
}

// The input `st` is, or nullptr: only regular files count (a device or fifo read and written
// is no file overwritten).
std::string input_named(const struct stat& st) {
  if (!S_ISREG(st.st_mode)) return {};
  std::lock_guard<std::mutex> guard(g_files_mutex);
  const NamedFile* f = find(g_inputs, id_of(st));
  return f ? f->name : std::string();
}

std::string output_named(const struct stat& st) {
  if (!S_ISREG(st.st_mode)) return {};
  std::lock_guard<std::mutex> guard(g_files_mutex);
  const NamedFile* f = find(g_outputs, id_of(st));
  return f ? f->name : std::string();
}

bool lock_held(const FileId& id) {
  std::lock_guard<std::mutex> guard(g_files_mutex);
  return std::find(g_locks_held.begin(), g_locks_held.end(), id) != g_locks_held.end();
}

}  // namespace

RemoveOnSignal::RemoveOnSignal(const std::string& path) {
  if (path.size() >= kPathMax) return;
  for (int i = 0; i < kSlots; ++i) {
    if (g_used[i]) continue;
    std::memcpy(g_temp[i], path.c_str(), path.size() + 1);
    slot_ = i;
    break;
  }
  if (slot_ < 0) return;
  if (g_registered++ == 0) {
    struct sigaction action {};
    action.sa_handler = remove_temporaries;
    sigemptyset(&action.sa_mask);
    for (std::size_t k = 0; k < std::size(kSignals); ++k) ::sigaction(kSignals[k], &action, &g_previous[k]);
  }
  g_used[slot_] = 1;
}

RemoveOnSignal::~RemoveOnSignal() {
  if (slot_ < 0) return;
  g_used[slot_] = 0;
  if (--g_registered == 0) restore_handlers();
}

namespace {

// A copy of the descriptor that `path` names as /dev/fd/N or /proc/self/fd/N when it is a pipe
// or a socket, else -1. Opened again by its name, such a pipe is a new reader that waits for a
// writer: the one that was there may have written everything and gone meanwhile (a named pipe
// that mo-detect opens to poll it, then reads through /dev/fd/N), and the open waits for ever.
int copy_of_open_pipe(const std::string& path) {
  std::string_view number;
  for (std::string_view prefix : {"/dev/fd/", "/proc/self/fd/"})
    if (path.size() > prefix.size() && path.compare(0, prefix.size(), prefix) == 0)
      number = std::string_view(path).substr(prefix.size());
  if (number.empty() || number.size() > 9 ||
      !std::all_of(number.begin(), number.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return -1;
  const int fd = std::stoi(std::string(number));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !(S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode))) return -1;
  return ::fcntl(fd, F_DUPFD_CLOEXEC, 0);
}

}  // namespace

int open_input(const std::string& path, const std::string& display_name) {
  const bool from_stdin = is_standard_input(path);
  const std::string name = !display_name.empty() ? display_name : input_name(path);
  int fd = STDIN_FILENO;
  if (!from_stdin) {
    fd = copy_of_open_pipe(path);
    if (fd < 0) fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  }
  if (fd < 0) throw Error(name + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode)) {
    if (const std::string output = output_named(st); !output.empty()) {
      if (!from_stdin) ::close(fd);
      throw Error(name + ": is also the output " + output + "; not read");
    }
    record(g_inputs, id_of(st), name);
  }
  return fd;
}

void expect_input(const std::string& path, const std::string& display_name) {
  if (is_standard_output(path)) return;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode))
    record(g_inputs, id_of(st), display_name.empty() ? path : display_name, /*expected=*/true);
}

void close_input(int fd) {
  if (fd < 0) return;
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode)) unrecord(g_inputs, id_of(st));
  if (fd != STDIN_FILENO) ::close(fd);
}

void refuse_if_input(const std::string& path, const std::string& display_name) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return;
  if (const std::string input = input_named(st); !input.empty())
    throw Error((display_name.empty() ? path : display_name) + ": is also an input (" + input + "); not overwritten");
}

void forget_inputs_and_outputs() {
  std::lock_guard<std::mutex> guard(g_files_mutex);
  g_inputs.clear();
  g_outputs.clear();
}

std::string temporary_prefix(const fs::path& target) { return "." + target.filename().string() + ".tmp-"; }

int remove_stale_temporaries(const fs::path& target) {
  fs::path folder = target.parent_path();
  if (folder.empty()) folder = ".";
  const std::string prefix = temporary_prefix(target);
  DIR* dir = ::opendir(folder.c_str());
  if (!dir) return 0;
  std::vector<std::string> candidates;
  while (const dirent* entry = ::readdir(dir)) {
    const std::string name = entry->d_name;
    if (name.size() == prefix.size() + 6 && name.compare(0, prefix.size(), prefix) == 0) candidates.push_back(name);
  }
  ::closedir(dir);
  int removed = 0;
  for (const auto& name : candidates) {
    const fs::path temp = folder / name;
    const int fd = ::open(temp.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
    if (fd < 0) continue;
    struct stat opened {}, now {};
    // A writer holds its temporary's flock until it renamed or removed it: a free lock is a
    // dead writer's. Removed while we hold the flock, so that a writer that just created it and
    // waits for its flock finds its name gone and starts again (replace_file).
    if (::fstat(fd, &opened) == 0 && S_ISREG(opened.st_mode) && ::flock(fd, LOCK_EX | LOCK_NB) == 0 &&
        ::lstat(temp.c_str(), &now) == 0 && id_of(now) == id_of(opened) && ::unlink(temp.c_str()) == 0)
      ++removed;
    ::close(fd);
  }
  return removed;
}

fs::path write_target(const fs::path& path) {
  fs::path at = path;
  for (int depth = 0;; ++depth) {
    struct stat st {};
    if (::lstat(at.c_str(), &st) != 0) {
      if (errno == ENOENT) return at;  // a new file (or a dangling link's target)
      fail(path, std::string("cannot inspect: ") + std::strerror(errno));
    }
    if (S_ISLNK(st.st_mode)) {
      if (depth >= 40) fail(path, "too many levels of symbolic links");
      std::vector<char> buffer(static_cast<std::size_t>(st.st_size > 0 ? st.st_size : 255) + 1);
      const ssize_t n = ::readlink(at.c_str(), buffer.data(), buffer.size());
      if (n < 0 || static_cast<std::size_t>(n) >= buffer.size())
        fail(path, std::string("cannot read the symbolic link ") + at.string());
      const fs::path link(std::string(buffer.data(), static_cast<std::size_t>(n)));
      at = link.is_absolute() ? link : at.parent_path() / link;
      continue;
    }
    if (!S_ISREG(st.st_mode)) fail(path, "not a regular file (" + kind_of(st.st_mode) + "); not replaced");
    return at;
  }
}

namespace {

// Creates the temporary file for `target` and takes its flock (the sign that its writer lives).
// A cleaner may remove it between the two (it saw a free flock): then its name is gone, and a
// new one is made. Returns the descriptor; `temp` receives the name.
int create_temporary(const fs::path& path, const fs::path& target, std::string& temp) {
  fs::path folder = target.parent_path();
  if (folder.empty()) folder = ".";
  for (int attempt = 0; attempt < 100; ++attempt) {
    temp = (folder / (temporary_prefix(target) + "XXXXXX")).string();
    const int fd = ::mkstemp(temp.data());
    if (fd < 0) fail(path, std::string("cannot create a temporary file: ") + std::strerror(errno));
    struct stat mine {}, named {};
    if (::flock(fd, LOCK_EX) == 0 && ::fstat(fd, &mine) == 0 && ::lstat(temp.c_str(), &named) == 0 &&
        id_of(mine) == id_of(named))
      return fd;
    ::close(fd);
  }
  fail(path, "cannot create a temporary file: its name keeps being removed");
}

}  // namespace

void replace_file(const fs::path& path, std::string_view bytes, const ReplaceOptions& options) {
  const fs::path target = write_target(path);
  refuse_if_input(target.string(), path.string());
  // Every profile write holds the profile's lock; a run that holds it since its read keeps it.
  std::unique_ptr<FileLock> lock;
  if (options.lock) {
    struct stat st {};
    if (::stat(target.c_str(), &st) != 0 || !lock_held(id_of(st))) lock = std::make_unique<FileLock>(path);
  }
  struct stat old {};
  const bool exists = ::stat(target.c_str(), &old) == 0;
  if (exists && options.refuse_read_only && (old.st_mode & S_IWUSR) == 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(old.st_mode & 07777));
    fail(path, std::string("read-only (mode ") + mode + "); not replaced");
  }
  fs::path folder = target.parent_path();
  if (folder.empty()) folder = ".";
  remove_stale_temporaries(target);
  std::string temp;
  const int fd = create_temporary(path, target, temp);
  RemoveOnSignal guard(temp);
  auto abandon = [&](const std::string& what, int error) {
    ::close(fd);
    ::unlink(temp.c_str());
    fail(path, what + ": " + std::strerror(error));
  };
  const mode_t mode = exists ? (old.st_mode & 07777) : static_cast<mode_t>(options.new_mode);
  if (::fchmod(fd, mode) != 0) abandon("cannot set the mode of the temporary file", errno);
  // Keep the owner too where we may (as root); elsewhere the file is ours anyway.
  if (exists && (old.st_uid != ::geteuid() || old.st_gid != ::getegid())) {
    if (::fchown(fd, old.st_uid, old.st_gid) != 0 && errno != EPERM) abandon("cannot set the owner", errno);
  }
  if (const int error = write_bytes(fd, bytes); error != 0) abandon("cannot write", error);
  if (::fsync(fd) != 0) abandon("cannot write (sync)", errno);
  // Renamed while its flock is held, so that no cleaner takes the finished file for a dead
  // writer's; the data are on disk already (fsync), so the close has nothing left to report.
  if (::rename(temp.c_str(), target.c_str()) != 0) abandon("cannot replace", errno);
  ::close(fd);
  // Make the rename itself durable.
  const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

void write_all(int fd, std::string_view bytes, std::string_view name) {
  const int error = write_bytes(fd, bytes);
  if (error == 0) return;
  if (error == EPIPE) throw BrokenPipe();
  throw Error(std::string(name) + ": write error: " + std::strerror(error));
}

OutputFile::OutputFile(const std::string& path) {
  if (core::is_standard_output(path)) {
    name_ = "<stdout>";
    fd_ = STDOUT_FILENO;
  } else {
    name_ = path;
    // Opened without O_TRUNC: nothing is truncated before we know it is no input of ours.
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0666);
    if (fd_ < 0) fail(path, std::string("cannot create: ") + std::strerror(errno));
    owns_fd_ = true;
  }
  struct stat st {};
  if (::fstat(fd_, &st) != 0) st.st_mode = 0;
  std::string clash;
  if (const std::string input = input_named(st); !input.empty()) {
    clash = "is also an input (" + input + "); not overwritten";
  } else if (const std::string output = output_named(st); !output.empty() && owns_fd_) {
    clash = "is also the output " + output + "; not overwritten";
  }
  if (!clash.empty()) {
    if (owns_fd_) ::close(fd_);
    fd_ = -1;
    fail(name_, clash);
  }
  if (owns_fd_ && S_ISREG(st.st_mode)) {
    if (::ftruncate(fd_, 0) != 0) {
      const int saved = errno;
      ::close(fd_);
      fd_ = -1;
      fail(name_, std::string("cannot create: ") + std::strerror(saved));
    }
  }
  if (S_ISREG(st.st_mode) && owns_fd_) {
    record(g_outputs, id_of(st), name_);
    recorded_ = true;
    id_ = {static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino)};
  }
  interactive_ = S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode) || S_ISCHR(st.st_mode);
  // A pipe holds 64 KiB by default: a stream of a gigabyte an hour then crosses it in 16,000
  // rounds of write, wake, read. Grown to the writer's buffer (256 KiB), a stream of the night
  // piped into mo-calibrate takes a quarter less wall time (1 MiB gains nothing more). Not
  // more: past the user's quota (pipe-user-pages-soft, 64 MiB) every new pipe of the user gets
  // one page, and a fleet's nights each hold a few. Where growing is refused, the pipe stays.
  (void)::fcntl(fd_, F_SETPIPE_SZ, 1 << 18);
}

OutputFile::~OutputFile() {
  forget();
  if (owns_fd_ && fd_ >= 0) ::close(fd_);
}

void OutputFile::forget() {
  if (recorded_) unrecord(g_outputs, FileId{static_cast<dev_t>(id_.first), static_cast<ino_t>(id_.second)});
  recorded_ = false;
}

void OutputFile::write(std::string_view bytes) {
  if (fd_ < 0) throw Error(name_ + ": write error: closed");
  write_all(fd_, bytes, name_);
}

void OutputFile::close() {
  forget();
  const int fd = fd_;
  fd_ = -1;
  if (owns_fd_ && fd >= 0 && ::close(fd) != 0) throw Error(name_ + ": close error: " + std::strerror(errno));
}

void write_document(const std::string& path, std::string_view bytes, const ReplaceOptions& options) {
  if (is_standard_output(path)) {
    // What the streams hold goes out first, so that the document stays in its place.
    std::cout.flush();
    std::fflush(stdout);
    write_all(STDOUT_FILENO, bytes, "<stdout>");
    return;
  }
  // A device or fifo is written to, not replaced; anything else (a regular file, a link to
  // one, nothing yet, a directory) goes to replace_file, which refuses what it must.
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode))) {
    OutputFile out(path);
    out.write(bytes);
    out.close();
    return;
  }
  replace_file(path, bytes, options);
}

FileLock::FileLock(const fs::path& path, const std::function<void(const std::string&)>& waiting) {
  target_ = write_target(path);
  bool reported = false;
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const int fd = ::open(target_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
      if (errno == ENOENT) return;  // nothing there yet: nothing to compare with
      fail(path, std::string("cannot open to lock: ") + std::strerror(errno));
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      if (errno != EWOULDBLOCK) {
        const int saved = errno;
        ::close(fd);
        fail(path, std::string("cannot lock: ") + std::strerror(saved));
      }
      if (waiting && !reported) waiting(path.string());
      reported = true;
      while (::flock(fd, LOCK_EX) != 0) {
        if (errno == EINTR) continue;
        const int saved = errno;
        ::close(fd);
        fail(path, std::string("cannot lock: ") + std::strerror(saved));
      }
    }
    // The holder before us may have renamed a new file over the one we locked: lock that one.
    struct stat locked {}, current {};
    if (::fstat(fd, &locked) == 0 && ::stat(target_.c_str(), &current) == 0 && locked.st_ino == current.st_ino &&
        locked.st_dev == current.st_dev) {
      fd_ = fd;
      id_ = {static_cast<std::uint64_t>(locked.st_dev), static_cast<std::uint64_t>(locked.st_ino)};
      {
        std::lock_guard<std::mutex> guard(g_files_mutex);
        g_locks_held.push_back(id_of(locked));
      }
      remove_stale_temporaries(target_);
      return;
    }
    ::close(fd);
  }
  fail(path, "cannot lock: the file keeps being replaced");
}

FileLock::~FileLock() { release(); }

void FileLock::release() {
  if (fd_ < 0) return;
  {
    std::lock_guard<std::mutex> guard(g_files_mutex);
    const FileId id{static_cast<dev_t>(id_.first), static_cast<ino_t>(id_.second)};
    const auto it = std::find(g_locks_held.begin(), g_locks_held.end(), id);
    if (it != g_locks_held.end()) g_locks_held.erase(it);
  }
  ::close(fd_);  // closing the descriptor releases the flock
  fd_ = -1;
}

}  // namespace momentum::core

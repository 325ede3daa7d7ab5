#pragma once
/// \file atomic_file.hpp
/// Private plumbing (src/common, not installed): the one way alphainv writes a file. A reader of
/// the target sees the old file or the whole new one, never a part, and once the call returns the
/// new file survives a crash or power cut:
///   1. the content goes to a temporary file `.<name>.tmp.<pid>.<n>` in the target's folder
///      (same file system, so the rename below is atomic),
///   2. the temporary file is fsync'ed,
///   3. it is renamed over the target,
///   4. the folder is fsync'ed (makes the rename itself durable).
/// On failure the temporary file is removed, the old target is left as it was, and
/// alphainv::Error is thrown with the target as its file and the errno text in its message.
/// Not real-time safe (allocates, blocks on the disk).

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>

#include "alphainv/error.hpp"

namespace alphainv::common {

/// fsync of the folder holding `target`, so that a rename into it is on disk. Best effort: some
/// file systems refuse fsync on a folder, and by now the target has been replaced, so failing the
/// write would misreport it.
inline void sync_folder_of(const std::filesystem::path& target) noexcept {
  const std::filesystem::path folder =
      target.parent_path().empty() ? std::filesystem::path(".") : target.parent_path();
  const int dir_fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    (void)::fsync(dir_fd);
    ::close(dir_fd);
  }
}

/// Steps 2-4 for an open temporary file: fsync `fd`, close it, rename `tmp` over `target`, fsync
/// the folder. On failure `tmp` is removed and Error thrown (file: `target`).
inline void sync_and_rename(int fd, const std::filesystem::path& tmp,
                            const std::filesystem::path& target) {
  const std::string name = target.string();
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    throw Error("cannot flush " + tmp.string() + " to disk: " + std::strerror(err), name);
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw Error("cannot close " + tmp.string() + ": " + std::strerror(err), name);
  }
  if (::rename(tmp.c_str(), target.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw Error("cannot rename " + tmp.string() + " to the target: " + std::strerror(err), name);
  }
  sync_folder_of(target);
}

/// Writes `content` to `target` atomically and durably (steps 1-4 above); the new file has mode
/// 0644 (less the umask). Throws Error (file: `target`; message: the step, the temporary file
/// and the errno text, e.g. "cannot create temporary file <dir>/.x.csv.tmp.12.0: Permission
/// denied"); the temporary file is then removed and the old target unchanged.
inline void write_file_atomically(const std::filesystem::path& target, std::string_view content) {
  static std::atomic<unsigned long> counter{0};
  const std::string name = target.string();
  std::filesystem::path tmp;
  int fd = -1;
  // A name left by a crashed process with a recycled pid is skipped, not overwritten.
  for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    tmp = target.parent_path() / ("." + target.filename().string() + ".tmp." +
                                  std::to_string(::getpid()) + "." + std::to_string(counter++));
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0 && errno != EEXIST) break;
  }
  if (fd < 0) {
    throw Error("cannot create temporary file " + tmp.string() + ": " + std::strerror(errno), name);
  }
  std::size_t written = 0;
  while (written < content.size()) {
    const ssize_t n = ::write(fd, content.data() + written, content.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      throw Error("cannot write " + tmp.string() + ": " + std::strerror(err), name);
    }
    written += static_cast<std::size_t>(n);
  }
  sync_and_rename(fd, tmp, target);
}

/// Steps 2-4 for a file another program wrote completely (e.g. gnuplot's PNG): fsync `written`,
/// rename it over `target` (both in the same folder), fsync the folder. On failure `written` is
/// removed and Error thrown (file: `target`).
inline void commit_file(const std::filesystem::path& written, const std::filesystem::path& target) {
  const int fd = ::open(written.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    ::unlink(written.c_str());
    throw Error("cannot open " + written.string() + ": " + std::strerror(err), target.string());
  }
  sync_and_rename(fd, written, target);
}

}  // namespace alphainv::common

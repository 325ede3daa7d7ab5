#pragma once
/// \file output_folder.hpp
/// Private plumbing (src/common, not installed): the one way alphainv writes a whole output
/// folder (omni_fit fit, diagnose, validate, simulate's dataset). A reader of the target sees the
/// old complete folder or the new complete one, never a mix, whatever kills the process:
///   1. OutputFolder(target) makes an empty sibling `.<name>.tmp.<pid>.<n>` (same file system);
///      the command writes every file into path() (each file atomically, atomic_file.hpp);
///   2. commit() fsyncs the sibling and swaps it with the target in one step
///      (renameat2 RENAME_EXCHANGE; a target that does not exist yet: a plain rename), fsyncs the
///      parent, then removes the old folder, now under the sibling's name;
///   3. without commit() (a failed or interrupted command) the destructor removes the sibling and
///      the target is untouched. A sibling left by a killed process (its pid gone) is removed by
///      the next OutputFolder of the same target.
/// A target that exists must be a folder that is empty or holds only the names `owned` lists (the
/// files the command writes): a folder holding anything else (`-o ~`) is refused before any work
/// is done, so a swap never moves a user's other files away.
/// Throws alphainv::Error naming the target and the errno text. Not real-time safe.

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <system_error>
#include <vector>

#include "alphainv/error.hpp"
#include "common/atomic_file.hpp"

namespace alphainv::common {

class OutputFolder {
 public:
  /// Checks `target` (see the file comment: missing, empty, or only names in `owned`), removes
  /// stale siblings of dead processes and creates the empty sibling. Throws Error (file: target).
  OutputFolder(const std::filesystem::path& target, std::initializer_list<const char*> owned)
      : target_(normalised(target)) {
    namespace fs = std::filesystem;
    const std::string name = target_.string();
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(target_, ec);
    if (st.type() != fs::file_type::not_found) {
      if (!fs::is_directory(st)) throw Error("expected a folder (or a new name), found a file", name);
      for (const auto& entry : fs::directory_iterator(target_, ec)) {
        const std::string n = entry.path().filename().string();
        bool known = false;
        for (const char* o : owned) known = known || n == o;
        if (!known) {
          throw Error("the output folder holds '" + n +
                          "', which this command does not write; give a new or empty folder "
                          "(the whole folder is replaced when the command succeeds)",
                      name);
        }
      }
      if (ec) throw Error("cannot list the output folder: " + ec.message(), name);
    }
    const fs::path parent = target_.parent_path();
    fs::create_directories(parent, ec);
    if (ec) throw Error("cannot create the folder " + parent.string() + ": " + ec.message(), name);
    remove_stale_siblings();
    static std::atomic<unsigned long> counter{0};
    for (int attempt = 0; attempt < 100; ++attempt) {
      tmp_ = parent / (prefix() + std::to_string(::getpid()) + "." + std::to_string(counter++));
      if (fs::create_directory(tmp_, ec)) return;
      if (ec && ec != std::errc::file_exists) break;
    }
    throw Error("cannot create the temporary folder " + tmp_.string() + ": " + ec.message(), name);
  }
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;
  /// Without commit(): removes the temporary folder; the target stays as it was.
  ~OutputFolder() {
    if (!committed_) {
      std::error_code ec;
      std::filesystem::remove_all(tmp_, ec);
    }
  }

  /// The folder to write into (the temporary sibling until commit()).
  const std::filesystem::path& path() const noexcept { return tmp_; }
  /// The folder the output will have once committed.
  const std::filesystem::path& target() const noexcept { return target_; }

  /// Puts the written folder in place of the target (step 2 of the file comment). Throws Error
  /// when the swap fails (the target is then unchanged and the temporary folder removed).
  void commit() {
    namespace fs = std::filesystem;
    const std::string name = target_.string();
    sync_tree(tmp_);
    std::error_code ec;
    const bool exists = fs::symlink_status(target_, ec).type() != fs::file_type::not_found;
    int rc = exists ? ::renameat2(AT_FDCWD, tmp_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE)
                    : ::renameat2(AT_FDCWD, tmp_.c_str(), AT_FDCWD, target_.c_str(), RENAME_NOREPLACE);
    if (rc != 0 && (errno == EINVAL || errno == ENOSYS)) {
      // A file system without renameat2's flags: move the old folder aside first (a reader may
      // then briefly find no target, never a mix).
      const fs::path old = fs::path(tmp_.string() + ".old");
      rc = exists ? ::rename(target_.c_str(), old.c_str()) : 0;
      if (rc == 0) rc = ::rename(tmp_.c_str(), target_.c_str());
      if (rc == 0 && exists) {
        committed_ = true;
        sync_folder_of(target_);
        fs::remove_all(old, ec);
        return;
      }
    }
    if (rc != 0) {
      const int err = errno;
      fs::remove_all(tmp_, ec);
      committed_ = true;  // nothing left to remove
      throw Error("cannot move " + tmp_.string() + " into place: " + std::strerror(err), name);
    }
    committed_ = true;
    sync_folder_of(target_);
    if (exists) fs::remove_all(tmp_, ec);  // the old folder, swapped to the sibling's name
  }

 private:
  static std::filesystem::path normalised(const std::filesystem::path& p) {
    std::filesystem::path n = std::filesystem::absolute(p).lexically_normal();
    if (!n.has_filename()) n = n.parent_path();  // "out/" names "out"
    return n;
  }
  std::string prefix() const { return "." + target_.filename().string() + ".tmp."; }

  /// Removes `.<name>.tmp.<pid>.*` siblings whose process is gone (a killed command's).
  void remove_stale_siblings() const {
    std::error_code ec;
    const std::string pre = prefix();
    std::vector<std::filesystem::path> stale;
    for (const auto& e : std::filesystem::directory_iterator(target_.parent_path(), ec)) {
      const std::string n = e.path().filename().string();
      if (n.compare(0, pre.size(), pre) != 0) continue;
      const long pid = std::strtol(n.c_str() + pre.size(), nullptr, 10);
      if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
        stale.push_back(e.path());
      }
    }
    for (const auto& p : stale) std::filesystem::remove_all(p, ec);
  }

  /// fsync of every file and folder under `dir` (the files were written atomically already;
  /// this makes the folders' entries durable before the swap).
  static void sync_tree(const std::filesystem::path& dir) {
    std::error_code ec;
    for (const auto& e : std::filesystem::recursive_directory_iterator(dir, ec)) {
      const int fd = ::open(e.path().c_str(), O_RDONLY | O_CLOEXEC);
      if (fd >= 0) {
        (void)::fsync(fd);
        ::close(fd);
      }
    }
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
      (void)::fsync(fd);
      ::close(fd);
    }
  }

  std::filesystem::path target_;
  std::filesystem::path tmp_;
  bool committed_ = false;
};

}  // namespace alphainv::common

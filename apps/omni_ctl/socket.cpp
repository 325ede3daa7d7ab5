// The daemon socket's file-system side (socket.hpp).
#include "socket.hpp"

#include <errno.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>

#include "alphainv/error.hpp"

namespace omni_ctl {

using alphainv::Error;
namespace fs = std::filesystem;

namespace {

std::string octal_mode(mode_t mode) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(mode & 07777));
  return buf;
}

bool fill_address(const std::string& path, sockaddr_un& addr) {
  if (path.empty() || path.size() >= sizeof addr.sun_path) return false;
  addr = sockaddr_un{};
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.data(), path.size());
  return true;
}

/// Why `dir` may not hold the daemon's socket, or empty. `private_only`: nobody but its owner may
/// even enter it (the daemon's rule); otherwise nobody else may write it (the client's rule: then
/// nobody else can have put the socket there).
std::string untrusted_folder(const std::string& dir, bool private_only) {
  struct stat st {};
  if (lstat(dir.c_str(), &st) != 0) return std::string("cannot stat it: ") + std::strerror(errno);
  if (!S_ISDIR(st.st_mode)) return "it is not a directory";
  if (st.st_uid != geteuid()) {
    return "it belongs to uid " + std::to_string(st.st_uid) + ", not to this user (uid " +
           std::to_string(geteuid()) + ")";
  }
  const mode_t forbidden = private_only ? 077 : 022;
  if ((st.st_mode & forbidden) != 0) {
    return "its mode is " + octal_mode(st.st_mode) + (private_only ? "; it must be 0700" :
                                                                     "; others may write it");
  }
  return {};
}

/// Creates the socket's folder 0700 when missing (its missing parents with the usual mode), or
/// checks the existing one; never changes a folder it did not create.
void prepare_socket_dir(const std::string& dir) {
  struct stat st {};
  if (lstat(dir.c_str(), &st) != 0) {
    if (errno != ENOENT) throw Error(std::string("cannot stat the socket folder: ") +
                                     std::strerror(errno), dir);
    std::error_code ec;
    const fs::path parent = fs::path(dir).parent_path();
    if (!parent.empty()) fs::create_directories(parent, ec);
    if (ec) throw Error("cannot create the socket folder's parent: " + ec.message(), dir);
    if (mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) {
      throw Error(std::string("cannot create the socket folder: ") + std::strerror(errno), dir);
    }
  }
  if (const std::string why = untrusted_folder(dir, true); !why.empty()) {
    throw Error("the socket folder cannot be used: " + why +
                    " (omni_ctl changes no folder it did not create; give --socket a path in a "
                    "folder of yours that is 0700, or one that does not exist yet)",
                dir);
  }
}

/// Removes a socket file nobody listens on; anything else at `path` is left alone and is an error.
void remove_stale_socket(const std::string& path) {
  struct stat st {};
  if (lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return;
    throw Error(std::string("cannot stat the socket path: ") + std::strerror(errno), path);
  }
  if (!S_ISSOCK(st.st_mode)) {
    throw Error("exists and is not a socket (" +
                    std::string(S_ISDIR(st.st_mode) ? "a folder" : S_ISREG(st.st_mode) ? "a file" :
                                                                   "not a socket") +
                    "); omni_ctl deletes nothing it did not create: choose another --socket",
                path);
  }
  const int probe = connect_raw(path);
  if (probe >= 0) {
    close(probe);
    throw Error("another omni_ctl daemon is already listening here", path);
  }
  if (unlink(path.c_str()) != 0 && errno != ENOENT) {
    throw Error(std::string("cannot remove the stale socket: ") + std::strerror(errno), path);
  }
}

}  // namespace

SocketLock::SocketLock(const std::string& socket_path) {
  const std::string lock_path = socket_path + ".lock";
  fd_ = open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0600);
  if (fd_ < 0) {
    throw Error(std::string("cannot open the daemon's lock file: ") + std::strerror(errno),
                lock_path);
  }
  struct stat st {};
  if (fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode) || st.st_uid != geteuid()) {
    close(fd_);
    fd_ = -1;
    throw Error("the daemon's lock file is not a regular file of this user", lock_path);
  }
  if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    close(fd_);
    fd_ = -1;
    if (err == EWOULDBLOCK) {
      throw Error("another omni_ctl daemon is already running on this socket (it holds the lock)",
                  lock_path);
    }
    throw Error(std::string("cannot lock: ") + std::strerror(err), lock_path);
  }
}

SocketLock::~SocketLock() {
  if (fd_ >= 0) close(fd_);  // releases the flock
}

SocketLock& SocketLock::operator=(SocketLock&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) close(fd_);
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}

void Listener::close_and_unlink() noexcept {
  if (fd < 0) return;
  close(fd);
  fd = -1;
  struct stat st {};
  if (lstat(path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode) && st.st_dev == dev &&
      st.st_ino == ino) {
    unlink(path.c_str());
  }
}

Listener listen_on(const std::string& path, SocketLock& lock) {
  sockaddr_un addr{};
  if (!fill_address(path, addr)) {
    throw Error("socket path empty or too long (at most " +
                    std::to_string(sizeof addr.sun_path - 1) + " bytes)",
                path);
  }
  prepare_socket_dir(fs::path(path).parent_path().string());
  lock = SocketLock(path);  // from here on no other daemon can be past this point on this path
  remove_stale_socket(path);
  Listener l;
  l.path = path;
  l.fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (l.fd < 0) throw Error(std::strerror(errno), path);
  // Created 0600 by the umask (single-threaded here), so there is no moment at which the socket
  // is open to others and no chmod afterwards.
  const mode_t old = umask(0177);
  const int rc = bind(l.fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  umask(old);
  struct stat st {};
  if (rc != 0 || lstat(path.c_str(), &st) != 0 || listen(l.fd, 8) != 0) {
    const std::string why = std::strerror(errno);
    close(l.fd);
    throw Error("cannot listen: " + why, path);
  }
  l.dev = st.st_dev;
  l.ino = st.st_ino;
  return l;
}

int connect_raw(const std::string& path) {
  sockaddr_un addr{};
  if (!fill_address(path, addr)) return -1;
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

Connection connect_daemon(const std::string& path) {
  Connection c;
  const int fd = connect_raw(path);
  if (fd < 0) return c;
  std::string why = untrusted_folder(fs::path(path).parent_path().string(), false);
  if (why.empty()) {
    ucred cred{};
    socklen_t len = sizeof cred;
    if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0) {
      why = std::string("SO_PEERCRED failed: ") + std::strerror(errno);
    } else if (cred.uid != geteuid()) {
      why = "the listener runs as uid " + std::to_string(cred.uid) + " (pid " +
            std::to_string(cred.pid) + "), not as this user (uid " + std::to_string(geteuid()) +
            ")";
    } else {
      c.fd = fd;
      return c;
    }
  } else {
    why = "its folder " + fs::path(path).parent_path().string() + " cannot be trusted: " + why;
  }
  close(fd);
  c.error = "refusing the listener at " + path + ": " + why +
            "; use --local to run here, or --socket to name your daemon's socket";
  return c;
}

}  // namespace omni_ctl

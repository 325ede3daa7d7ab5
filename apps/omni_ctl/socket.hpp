#pragma once
// The daemon socket's file-system side, for both ends (docs/omni_ctl-protocol.md, "Socket"):
// the daemon's folder and lock, listening, the client's checks before it trusts a listener.
// Nothing here deletes or chmods anything omni_ctl did not create: a path that is not what it
// should be is an error that names it.
#include <sys/types.h>

#include <string>

namespace omni_ctl {

/// One daemon per socket: the flock(2) on "<socket>.lock" held for the daemon's life (released by
/// the kernel when the process ends, however it ends). The lock file itself stays.
class SocketLock {
 public:
  SocketLock() = default;
  /// Takes the lock of `socket_path` without waiting; throws alphainv::Error naming the lock file
  /// when another process holds it or the file is not a regular file of ours.
  explicit SocketLock(const std::string& socket_path);
  ~SocketLock();
  SocketLock(SocketLock&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
  SocketLock& operator=(SocketLock&& o) noexcept;
  SocketLock(const SocketLock&) = delete;
  SocketLock& operator=(const SocketLock&) = delete;

 private:
  int fd_ = -1;
};

/// A listening socket and what is needed to remove exactly it at the end.
struct Listener {
  int fd = -1;
  std::string path;
  dev_t dev = 0;  ///< of the socket file bound
  ino_t ino = 0;
  /// Closes the socket and unlinks the path if it is still the socket bound here.
  void close_and_unlink() noexcept;
};

/// The daemon side: creates the socket's folder 0700 when it does not exist (or checks that an
/// existing one is a directory of this user that nobody else may enter), takes the lock, removes
/// a stale socket (a socket file nobody listens on), binds 0600 and listens. Throws
/// alphainv::Error naming the path and what is wrong with it.
Listener listen_on(const std::string& path, SocketLock& lock);

/// What connect_daemon() found.
struct Connection {
  int fd = -1;         ///< connected and trusted, or −1
  std::string error;   ///< with fd −1: why a listener was found but not trusted; empty: none there
};

/// The client side: connects to `path` and trusts it only when the socket's folder is a
/// directory owned by this user that no other user may write, and the listener's SO_PEERCRED uid
/// is this user's. fd −1 and an empty error: nobody listens there.
Connection connect_daemon(const std::string& path);

/// Connects to `path` without any check; −1 when nobody listens. (The daemon's stale-socket probe.)
int connect_raw(const std::string& path);

}  // namespace omni_ctl

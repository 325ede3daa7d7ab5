#pragma once
// Runs a program as a child process (fork/exec) for end-to-end tests: environment overrides,
// stdout/stderr captured to files, a timeout, and signals. Test-only, POSIX.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace alphainv::test {

struct ProcessResult {
  int exit_code = -1;  ///< exit status, or 128 + signal, or −1 when killed for the timeout
  std::string out, err;
};

class Subprocess {
 public:
  /// `run_as_uid` ≥ 0: the child drops to that uid and gid before exec (the parent must be root).
  Subprocess(const std::vector<std::string>& argv,
             const std::map<std::string, std::string>& env = {}, int run_as_uid = -1)
      : out_path_(tmp("out")), err_path_(tmp("err")) {
    pid_ = fork();
    if (pid_ == 0) {
      for (const auto& [k, v] : env) setenv(k.c_str(), v.c_str(), 1);
      const int out = open(out_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      const int err = open(err_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      dup2(out, 1);
      dup2(err, 2);
      if (run_as_uid >= 0 && (setgid(static_cast<gid_t>(run_as_uid)) != 0 ||
                              setuid(static_cast<uid_t>(run_as_uid)) != 0)) {
        _exit(126);
      }
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
  }
  ~Subprocess() {
    if (pid_ > 0 && !done_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    unlink(out_path_.c_str());
    unlink(err_path_.c_str());
  }
  pid_t pid() const { return pid_; }
  void signal(int sig) { kill(pid_, sig); }
  /// Waits up to timeout_s; kills the child when it is still running.
  ProcessResult wait(double timeout_s = 60.0) {
    ProcessResult r;
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    int status = 0;
    for (;;) {
      const pid_t w = waitpid(pid_, &status, WNOHANG);
      if (w == pid_) break;
      if (std::chrono::steady_clock::now() > end) {
        kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        done_ = true;
        r.exit_code = -1;
        r.out = slurp(out_path_);
        r.err = slurp(err_path_);
        return r;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    done_ = true;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    r.out = slurp(out_path_);
    r.err = slurp(err_path_);
    return r;
  }
  /// stderr so far (the child may still run).
  std::string err_so_far() const { return slurp(err_path_); }

  static std::string slurp(const std::string& path) {
    std::ifstream f(path);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  }

 private:
  static std::string tmp(const char* what) {
    static int n = 0;
    return "/tmp/alphainv_subprocess_" + std::to_string(getpid()) + "_" + std::to_string(n++) +
           "." + what;
  }
  std::string out_path_, err_path_;
  pid_t pid_ = -1;
  bool done_ = false;
};

inline ProcessResult run_process(const std::vector<std::string>& argv,
                                 const std::map<std::string, std::string>& env = {},
                                 double timeout_s = 60.0) {
  Subprocess p(argv, env);
  return p.wait(timeout_s);
}

}  // namespace alphainv::test

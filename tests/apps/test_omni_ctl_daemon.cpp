// omni_ctl --daemon end to end with a real client over the Unix socket: permissions, every
// command, malformed and oversized messages (error replies; the loop keeps its deadlines), a
// recorded run with a state stream, the omni_ctl client mode, faults and SIGTERM.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "alphainv/data/dataset.hpp"
#include "support/subprocess.hpp"

using namespace alphainv;
using alphainv::test::ProcessResult;
using alphainv::test::run_process;
using alphainv::test::Subprocess;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) {
  const fs::path p =
      fs::temp_directory_path() / ("alphainv_test_daemon_" + std::to_string(getpid()) + "_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

/// A protocol client: one connection, newline-delimited JSON.
class Client {
 public:
  explicit Client(const std::string& path) {
    fd_ = socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    connected_ = connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  }
  ~Client() { close(fd_); }
  bool connected() const { return connected_; }
  void send_raw(const std::string& bytes) {
    ASSERT_EQ(send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL),
              static_cast<ssize_t>(bytes.size()));
  }
  /// The next line as JSON; null on timeout or when the daemon closed the connection.
  json next(double timeout_s = 5.0) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
      const auto nl = buffer_.find('\n');
      if (nl != std::string::npos) {
        const std::string line = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        return json::parse(line);
      }
      if (std::chrono::steady_clock::now() > end) return nullptr;
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, 20) <= 0) continue;
      char buf[4096];
      const ssize_t n = recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) {
        closed_ = true;
        return nullptr;
      }
      buffer_.append(buf, static_cast<std::size_t>(n));
    }
  }
  /// Sends a request and returns the first reply that has "ok" (skipping events).
  json request(const std::string& line) {
    send_raw(line + "\n");
    for (int i = 0; i < 10000; ++i) {
      json r = next();
      if (r.is_null() || r.contains("ok")) return r;
    }
    return nullptr;
  }
  bool closed() const { return closed_; }

 private:
  int fd_ = -1;
  bool connected_ = false;
  bool closed_ = false;
  std::string buffer_;
};

struct Daemon {
  fs::path dir;
  std::string socket;
  std::unique_ptr<Subprocess> process;

  Daemon(const std::string& name, std::vector<std::string> extra = {}) {
    dir = temp_dir(name);
    socket = (dir / "run" / "omni_ctl.sock").string();
    std::vector<std::string> args = {OMNI_CTL_BIN, "--daemon", "--device",  "sim",
                                     "--socket",   socket,     "--no-mlock"};
    args.insert(args.end(), extra.begin(), extra.end());
    process = std::make_unique<Subprocess>(args);
    for (int i = 0; i < 400 && !fs::exists(socket); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  ~Daemon() { fs::remove_all(dir); }
};

}  // namespace

TEST(OmniCtlDaemon, ServesCommandsRejectsBadMessagesAndKeepsTheLoopRunning) {
  Daemon d("serve");
  ASSERT_TRUE(fs::exists(d.socket)) << d.process->err_so_far();
  struct stat st {};
  ASSERT_EQ(stat(fs::path(d.socket).parent_path().c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700u);
  ASSERT_EQ(stat(d.socket.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));

  Client c(d.socket);
  ASSERT_TRUE(c.connected());
  const json s0 = c.request(R"({"cmd":"status"})");
  ASSERT_TRUE(s0.value("ok", false)) << s0;
  EXPECT_EQ(s0["kp"], 2.0);
  EXPECT_FALSE(s0["running"].get<bool>());
  const auto t0 = std::chrono::steady_clock::now();

  // Malformed messages: an error reply that says what is wrong; the connection stays usable.
  const std::pair<std::string, std::string> bad[] = {
      {"{bad json", "malformed JSON"},
      {"[1,2]", "expected an object"},
      {R"({"cmd":7})", "expected an object"},
      {R"({"cmd":"fly"})", "unknown cmd 'fly'"},
      {R"({"cmd":"gains","kp":50})", "'kp'"},
      {R"({"cmd":"gains","kp":"high"})", "'kp': expected a number"},
      {R"({"cmd":"gains"})", "'kp'"},
      {R"({"cmd":"stream","rate_hz":1e9})", "'rate_hz'"},
      {R"({"cmd":"run","waveform":"sine"})", "'freq_hz'"},
      {R"({"cmd":"run","waveform":"zigzag"})", "'waveform'"},
      {R"({"cmd":"run","waveform":"sine","freq_hz":3,"amplitude_rad":5})", "'amplitude_rad'"},
      {R"({"cmd":"run","waveform":"step","record":"relative/dir"})", "'record'"},
      {std::string(5000, 'x'), "message too long"},
  };
  for (int round = 0; round < 100; ++round) {
    for (const auto& [msg, why] : bad) {
      const json r = c.request(msg);
      ASSERT_FALSE(r.is_null()) << msg;
      EXPECT_FALSE(r["ok"].get<bool>()) << msg;
      EXPECT_NE(r["error"].get<std::string>().find(why), std::string::npos) << r;
    }
  }
  // The loop did not notice: it kept ticking at 1 kHz and nothing faulted.
  const json s1 = c.request(R"({"cmd":"status"})");
  ASSERT_TRUE(s1.value("ok", false));
  const double elapsed_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const long ticks = s1["ticks"].get<long>() - s0["ticks"].get<long>();
  EXPECT_NEAR(static_cast<double>(ticks), elapsed_ms, 0.1 * elapsed_ms + 20);
  // Under SCHED_FIFO no miss is expected; under the normal scheduler a loaded machine may cost a
  // few, but not because of the messages.
  const long misses = s1["deadline_misses"].get<long>() - s0["deadline_misses"].get<long>();
  EXPECT_LE(misses, s1["realtime"].get<bool>() ? 2 : 2 + ticks / 100);

  // Gains within limits.
  EXPECT_TRUE(c.request(R"({"cmd":"gains","kp":3})").value("ok", false));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(c.request(R"({"cmd":"status"})")["kp"], 3.0);

  // A recorded run with a 100 Hz state stream.
  const fs::path rec = d.dir / "rec";
  const json run = c.request(R"({"cmd":"run","waveform":"sine","freq_hz":3,"amplitude_rad":0.05,)"
                             R"("duration_s":0.5,"record":")" +
                             rec.string() + R"("})");
  ASSERT_TRUE(run.value("ok", false)) << run;
  EXPECT_FALSE(c.request(R"({"cmd":"run","waveform":"hold"})").value("ok", true));  // busy
  ASSERT_TRUE(c.request(R"({"cmd":"stream","rate_hz":100})").value("ok", false));
  int states = 0;
  double max_theta = 0.0;
  json done;
  for (int i = 0; i < 1000; ++i) {
    const json ev = c.next();
    ASSERT_FALSE(ev.is_null());
    if (ev["event"] == "state") {
      ++states;
      max_theta = std::max(max_theta, std::abs(ev["theta_rad"].get<double>()));
    }
    if (ev["event"] == "run_done") {
      done = ev;
      break;
    }
  }
  ASSERT_FALSE(done.is_null());
  EXPECT_EQ(done["run_id"], run["run_id"]);
  EXPECT_TRUE(done["fault"].is_null());
  EXPECT_GE(states, 25);  // ~50 expected in 0.5 s
  EXPECT_GT(max_theta, 0.02);
  // One overrun can pass several deadlines: the run's ticks are its 500 periods less those.
  EXPECT_EQ(done["rows"].get<long>(), 500 - done["timing"]["skipped_ticks"].get<long>());
  EXPECT_GE(done["timing"]["skipped_ticks"].get<long>(), done["timing"]["deadline_misses"].get<long>());
  const Dataset ds = read_dataset_index(rec);
  EXPECT_EQ(ds.controller.kp, 3.0);
  EXPECT_EQ(static_cast<long>(read_run(ds, 0).size()), done["rows"].get<long>());

  // Stop a run that would last a minute.
  ASSERT_TRUE(c.request(R"({"cmd":"run","waveform":"square","freq_hz":1,"duration_s":60})")
                  .value("ok", false));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(c.request(R"({"cmd":"stop"})").value("ok", false));
  bool stopped = false;
  for (int i = 0; i < 1000 && !stopped; ++i) {
    const json ev = c.next();
    ASSERT_FALSE(ev.is_null());
    stopped = ev["event"] == "run_done" && ev["stopped"].get<bool>();
  }
  EXPECT_TRUE(stopped);

  // omni_ctl itself as the client: it finds the daemon and runs there.
  const fs::path rec2 = d.dir / "rec2";
  const ProcessResult cli = run_process({OMNI_CTL_BIN, "--joint", "yaw", "--step", "--duration",
                                         "0.3s", "--socket", d.socket, "--record", rec2.string()});
  EXPECT_EQ(cli.exit_code, 0) << cli.err;
  EXPECT_NE(cli.err.find("using the daemon"), std::string::npos) << cli.err;
  EXPECT_EQ(read_dataset_index(rec2).runs[0].kind, "step");

  // An unterminated message beyond the limit: error, then the daemon hangs up on that client.
  Client flood(d.socket);
  flood.send_raw(std::string(10000, '{'));
  const json r = flood.next();
  ASSERT_FALSE(r.is_null());
  EXPECT_NE(r["error"].get<std::string>().find("message too long"), std::string::npos);
  EXPECT_TRUE(flood.next(2.0).is_null());
  EXPECT_TRUE(flood.closed());

  // SIGTERM: exit 0, motor zeroed, socket removed, the client told.
  d.process->signal(SIGTERM);
  const ProcessResult end = d.process->wait(10.0);
  EXPECT_EQ(end.exit_code, 0) << end.err;
  EXPECT_NE(end.err.find("stopped by signal"), std::string::npos) << end.err;
  EXPECT_FALSE(fs::exists(d.socket));
  json last;
  for (json ev = c.next(); !ev.is_null(); ev = c.next()) last = ev;
  EXPECT_EQ(last["event"], "daemon_exit");
}

TEST(OmniCtlDaemon, AFaultStopsTheDaemonAndTellsTheClient) {
  Daemon d("fault", {"--sim-fault", "corrupt@0.8"});
  ASSERT_TRUE(fs::exists(d.socket)) << d.process->err_so_far();
  Client c(d.socket);
  ASSERT_TRUE(c.connected());
  const fs::path rec = d.dir / "rec";
  ASSERT_TRUE(c.request(R"({"cmd":"run","waveform":"sine","freq_hz":2,"duration_s":30,"record":")" +
                        rec.string() + R"("})")
                  .value("ok", false));
  json done, exit_event;
  for (json ev = c.next(); !ev.is_null(); ev = c.next()) {
    if (ev["event"] == "run_done") done = ev;
    if (ev["event"] == "daemon_exit") exit_event = ev;
  }
  ASSERT_FALSE(done.is_null());
  EXPECT_NE(done["fault"].get<std::string>().find("corrupt input report"), std::string::npos);
  ASSERT_FALSE(exit_event.is_null());
  const ProcessResult end = d.process->wait(10.0);
  EXPECT_EQ(end.exit_code, 3) << end.err;
  EXPECT_NE(end.err.find("FAULT: corrupt input report"), std::string::npos) << end.err;
  const RunData run = read_run(read_dataset_index(rec), 0);
  EXPECT_GT(run.size(), 100u);
  EXPECT_EQ(run.column("torque_enable")->back(), 0.0);
}

TEST(OmniCtlDaemon, SecondDaemonOnTheSameSocketIsRefused) {
  Daemon d("twice");
  ASSERT_TRUE(fs::exists(d.socket));
  const ProcessResult second = run_process(
      {OMNI_CTL_BIN, "--daemon", "--device", "sim", "--socket", d.socket, "--no-mlock"}, {}, 10.0);
  EXPECT_EQ(second.exit_code, 4) << second.err;
  EXPECT_NE(second.err.find("already listening"), std::string::npos) << second.err;
  d.process->signal(SIGTERM);
  EXPECT_EQ(d.process->wait(10.0).exit_code, 0);
}

TEST(OmniCtlDaemon, PeersOfAnotherUidAreRefused) {
  if (getuid() != 0) GTEST_SKIP() << "needs root to connect as another user";
  Daemon d("peercred");
  ASSERT_TRUE(fs::exists(d.socket)) << d.process->err_so_far();
  // The 0700 folder already keeps others out; open it up so only SO_PEERCRED stands in the way.
  ASSERT_EQ(chmod(fs::path(d.socket).parent_path().c_str(), 0755), 0);
  ASSERT_EQ(chmod(d.socket.c_str(), 0666), 0);
  int pipefd[2];
  ASSERT_EQ(pipe(pipefd), 0);
  const pid_t child = fork();
  if (child == 0) {
    close(pipefd[0]);
    if (setgid(65534) != 0 || setuid(65534) != 0) _exit(2);
    Client c(d.socket);
    if (!c.connected()) _exit(3);
    const json r = c.next(5.0);
    const std::string text = r.is_null() ? "null" : r.dump();
    if (write(pipefd[1], text.data(), text.size()) < 0) _exit(4);
    _exit(c.next(2.0).is_null() && c.closed() ? 0 : 5);
  }
  close(pipefd[1]);
  int status = 0;
  waitpid(child, &status, 0);
  char buf[512] = {};
  const ssize_t n = read(pipefd[0], buf, sizeof buf - 1);
  close(pipefd[0]);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  ASSERT_GT(n, 0);
  EXPECT_NE(std::string(buf).find("permission denied"), std::string::npos) << buf;
  // The daemon's own user still gets in.
  Client ok(d.socket);
  EXPECT_TRUE(ok.request(R"({"cmd":"status"})").value("ok", false));
  d.process->signal(SIGTERM);
  EXPECT_EQ(d.process->wait(10.0).exit_code, 0);
}

// omni_ctl --daemon: owns the device, keeps the 1 kHz loop running (holding position when idle)
// on its own SCHED_FIFO thread, and serves newline-delimited JSON commands on a Unix socket
// (docs/omni_ctl-protocol.md). This thread never touches the loop except through the runner's
// lock-free command ring; a malformed or oversized message costs only this thread's time.
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "alphainv/device/loop_runner.hpp"
#include "alphainv/error.hpp"
#include "options.hpp"

namespace omni_ctl {
namespace {

using namespace alphainv;
using json = nlohmann::json;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr std::size_t kMaxMessageBytes = 4096;  ///< one request line, newline excluded
constexpr int kMaxClients = 16;

struct Client {
  int fd = -1;
  std::string in;          // bytes received, not yet a whole line
  double stream_hz = 0.0;  // 0: no state stream
  Clock::time_point next_state{};
  bool close_after_write = false;
};

/// Sends one JSON line without blocking; false when the client must be dropped.
bool send_line(Client& c, const json& j) {
  const std::string line = j.dump() + "\n";
  const ssize_t n = send(c.fd, line.data(), line.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  return n == static_cast<ssize_t>(line.size());
}

json error_reply(const std::string& message) { return {{"ok", false}, {"error", message}}; }

/// The number at `key` of `msg`, or `fallback` when absent; throws Error naming the key.
double number_field(const json& msg, const char* key, double fallback, double lo, double hi) {
  if (!msg.contains(key)) return fallback;
  const json& v = msg.at(key);
  if (!v.is_number()) throw Error("expected a number, got " + v.dump(), {}, 0, key);
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < lo || x > hi) {
    throw Error("expected " + std::to_string(lo) + " <= value <= " + std::to_string(hi) + ", got " +
                    v.dump(),
                {}, 0, key);
  }
  return x;
}

/// Creates the socket's folder 0700 (or checks an existing one is ours and private).
void prepare_socket_dir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create the socket folder: " + ec.message(), dir.string());
  struct stat st {};
  if (stat(dir.c_str(), &st) != 0) throw Error(std::strerror(errno), dir.string());
  if (st.st_uid != geteuid()) {
    throw Error("the socket folder belongs to uid " + std::to_string(st.st_uid) + ", not us",
                dir.string());
  }
  if (chmod(dir.c_str(), 0700) != 0) throw Error(std::strerror(errno), dir.string());
}

int listen_on(const std::string& path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof addr.sun_path) throw Error("socket path too long", path);
  prepare_socket_dir(fs::path(path).parent_path());
  // A socket file with nobody behind it is stale; one with a daemon behind it is not ours.
  if (fs::exists(path)) {
    const int probe = connect_daemon(path);
    if (probe >= 0) {
      close(probe);
      throw Error("another omni_ctl daemon is already listening here", path);
    }
    fs::remove(path);
  }
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) throw Error(std::strerror(errno), path);
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  const mode_t old = umask(0077);
  const int rc = bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  umask(old);
  if (rc != 0 || chmod(path.c_str(), 0600) != 0 || listen(fd, 8) != 0) {
    const std::string why = std::strerror(errno);
    close(fd);
    throw Error("cannot listen: " + why, path);
  }
  return fd;
}

json state_json(const rt::TickRecord& r) {
  return {{"event", "state"},
          {"t_s", r.t_s},
          {"r_rad", r.r_rad},
          {"theta_rad", r.theta_rad},
          {"command_v", r.command_v},
          {"alpha", r.alpha},
          {"C", r.damping},
          {"beta_tilde", r.beta_tilde},
          {"theta_pred_rad", r.theta_pred_rad},
          {"enable", r.enable}};
}

/// The daemon's state: the loop it serves, its clients and their runs. One object, handed to the
/// loop thread (set_realtime, on_run_done) and run by the main thread (serve).
class Server {
 public:
  /// Serves `runner`, set up from `setup`, until `stop` turns true (a signal).
  Server(const Options& opt, device::LoopRunner& runner, const LoopSetup& setup,
         const std::atomic<bool>& stop)
      : opt_(opt), runner_(runner), setup_(setup), stop_(stop) {}

  /// What the loop thread obtained: SCHED_FIFO or not (the `status` reply's `realtime`).
  void set_realtime(bool fifo) { realtime_.store(fifo); }

  void on_run_done(const device::RunResult& r) {
    std::lock_guard<std::mutex> lock(done_mutex_);
    done_.push_back(r);
  }

  /// Serves until `loop_running` turns false or a stop is requested.
  void serve(int listen_fd, const std::atomic<bool>& loop_running) {
    while (loop_running.load() && !stop_.load()) {
      std::vector<pollfd> fds;
      fds.push_back({listen_fd, POLLIN, 0});
      for (const Client& c : clients_) fds.push_back({c.fd, POLLIN, 0});
      const int timeout_ms = next_timeout_ms();
      const int n = poll(fds.data(), fds.size(), timeout_ms);
      if (n < 0 && errno != EINTR) {
        spdlog::error("poll: {}", std::strerror(errno));
        break;
      }
      if (n > 0 && (fds[0].revents & POLLIN)) accept_clients(listen_fd);
      for (std::size_t i = 1; i < fds.size(); ++i) {
        if (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) read_client(fds[i].fd);
      }
      drop_closed();
      deliver_run_results();
      stream_states();
    }
  }

  /// Tells every client the loop stopped, then closes them.
  void broadcast_end(const json& event) {
    deliver_run_results();
    for (Client& c : clients_) {
      (void)send_line(c, event);
      close(c.fd);
    }
    clients_.clear();
  }

 private:
  int next_timeout_ms() const {
    int ms = 20;
    const auto now = Clock::now();
    for (const Client& c : clients_) {
      if (c.stream_hz > 0.0) {
        const auto wait =
            std::chrono::duration_cast<std::chrono::milliseconds>(c.next_state - now).count();
        ms = std::min<int>(ms, std::max<int>(0, static_cast<int>(wait)));
      }
    }
    return ms;
  }

  void accept_clients(int listen_fd) {
    for (;;) {
      const int fd = accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) return;
      ucred cred{};
      socklen_t len = sizeof cred;
      Client c;
      c.fd = fd;
      if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0 || cred.uid != geteuid()) {
        spdlog::warn("refused a client with uid {} (only uid {} may connect)", cred.uid, geteuid());
        (void)send_line(c, error_reply("permission denied: only the daemon's user may connect"));
        close(fd);
        continue;
      }
      if (clients_.size() >= static_cast<std::size_t>(kMaxClients)) {
        (void)send_line(
            c, error_reply("too many clients (limit " + std::to_string(kMaxClients) + ")"));
        close(fd);
        continue;
      }
      spdlog::info("client connected (pid {})", cred.pid);
      clients_.push_back(c);
    }
  }

  Client* find(int fd) {
    for (Client& c : clients_) {
      if (c.fd == fd) return &c;
    }
    return nullptr;
  }

  void read_client(int fd) {
    Client* c = find(fd);
    if (c == nullptr) return;
    char buf[4096];
    for (;;) {
      const ssize_t n = recv(fd, buf, sizeof buf, 0);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
        c->close_after_write = true;
        return;
      }
      if (n < 0) break;
      c->in.append(buf, static_cast<std::size_t>(n));
      std::size_t nl;
      while ((nl = c->in.find('\n')) != std::string::npos) {
        std::string line = c->in.substr(0, nl);
        c->in.erase(0, nl + 1);
        if (line.size() > kMaxMessageBytes) {
          reply(*c, error_reply("message too long: " + std::to_string(line.size()) +
                                " bytes, the limit is " + std::to_string(kMaxMessageBytes)));
          continue;
        }
        handle(*c, line);
      }
      if (c->in.size() > kMaxMessageBytes) {
        // No newline within the limit: answer once, then drop the connection.
        reply(*c, error_reply("message too long: no newline within " +
                              std::to_string(kMaxMessageBytes) + " bytes; closing"));
        c->close_after_write = true;
        return;
      }
    }
  }

  void reply(Client& c, const json& j) {
    if (!send_line(c, j)) c.close_after_write = true;
  }

  void handle(Client& c, const std::string& line) {
    json msg;
    try {
      msg = json::parse(line);
    } catch (const json::exception& e) {
      reply(c, error_reply(std::string("malformed JSON: ") + e.what()));
      return;
    }
    if (!msg.is_object() || !msg.contains("cmd") || !msg["cmd"].is_string()) {
      reply(c, error_reply("expected an object with a string \"cmd\""));
      return;
    }
    const std::string cmd = msg["cmd"].get<std::string>();
    try {
      if (cmd == "status") {
        reply(c, {{"ok", true},
                  {"cmd", "status"},
                  {"kp", runner_.kp()},
                  {"running", runner_.running_waveform()},
                  {"ticks", runner_.ticks()},
                  {"deadline_misses", runner_.deadline_misses()},
                  {"realtime", realtime_.load()},
                  {"device", setup_.transport->describe()},
                  {"model", setup_.model_source},
                  {"max_command_v", runner_.config().safety.max_command_v},
                  {"kp_max", runner_.config().kp_max}});
      } else if (cmd == "gains") {
        if (!msg.contains("kp")) throw Error("missing", {}, 0, "kp");
        const double kp = number_field(msg, "kp", 0.0, 0.0, runner_.config().kp_max);
        device::LoopCommand lc;
        lc.kind = device::LoopCommand::Kind::kSetKp;
        lc.kp = kp;
        if (!runner_.post(lc)) throw Error("the loop's command queue is full; retry");
        reply(c, {{"ok", true}, {"cmd", "gains"}, {"kp", kp}});
      } else if (cmd == "stream") {
        c.stream_hz = number_field(msg, "rate_hz", 0.0, 0.0, 1000.0);
        c.next_state = Clock::now();
        reply(c, {{"ok", true}, {"cmd", "stream"}, {"rate_hz", c.stream_hz}});
      } else if (cmd == "stop") {
        device::LoopCommand lc;
        lc.kind = device::LoopCommand::Kind::kStop;
        if (!runner_.post(lc)) throw Error("the loop's command queue is full; retry");
        reply(c, {{"ok", true}, {"cmd", "stop"}});
      } else if (cmd == "run") {
        start_run(c, msg);
      } else {
        reply(c,
              error_reply("unknown cmd '" + cmd + "' (known: run, gains, stream, stop, status)"));
      }
    } catch (const Error& e) {
      reply(c, error_reply(e.what()));
    } catch (const json::exception& e) {
      reply(c, error_reply(e.what()));
    }
  }

  void start_run(Client& c, const json& msg) {
    if (!msg.contains("waveform") || !msg["waveform"].is_string()) {
      throw Error("expected one of sine, square, step, hold", {}, 0, "waveform");
    }
    Options o = opt_;
    const std::string name = msg["waveform"].get<std::string>();
    o.wave = wave_from_name(name);
    if (!o.wave) {
      throw Error("expected one of sine, square, step, hold, got '" + name + "'", {}, 0,
                  "waveform");
    }
    const bool periodic = is_periodic(*o.wave);
    if (periodic && !msg.contains("freq_hz")) throw Error("missing for " + name, {}, 0, "freq_hz");
    o.freq_hz = number_field(msg, "freq_hz", 0.0, periodic ? 1e-3 : 0.0, 100.0);
    o.amplitude_rad = number_field(msg, "amplitude_rad", 0.07, 0.0, 1.0);
    o.duration_s = number_field(msg, "duration_s", 10.0, 1e-3, 86400.0);
    o.record_dir.clear();
    if (msg.contains("record")) {
      if (!msg["record"].is_string() || msg["record"].get<std::string>().empty() ||
          msg["record"].get<std::string>()[0] != '/') {
        throw Error("expected an absolute folder path", {}, 0, "record");
      }
      o.record_dir = msg["record"].get<std::string>();
    }
    if (msg.contains("force") && !msg["force"].is_boolean()) {
      throw Error("expected true or false", {}, 0, "force");
    }
    o.force_record = msg.value("force", false);
    if (!owner_.empty() || runner_.running_waveform()) {
      throw Error("a run is in progress; send stop first", {}, 0, "cmd");
    }
    const std::uint32_t id = ++last_run_id_;
    const device::LoopCommand run = make_run_command(o, id);
    if (!o.record_dir.empty()) {
      o.command_line = msg.contains("command_line") && msg["command_line"].is_string()
                           ? msg["command_line"].get<std::string>()
                           : "omni_ctl --daemon: " + msg.dump();
      runner_.add_recording(id, make_recording(o, run, setup_));
    }
    if (!runner_.post(run)) throw Error("the loop's command queue is full; retry");
    owner_[id] = c.fd;
    spdlog::info("run {}: {} {} Hz, {} rad, {} s{}", id, name, o.freq_hz, o.amplitude_rad,
                 o.duration_s, o.record_dir.empty() ? "" : ", recording to " + o.record_dir);
    reply(c, {{"ok", true}, {"cmd", "run"}, {"run_id", id}});
  }

  void deliver_run_results() {
    std::deque<device::RunResult> done;
    {
      std::lock_guard<std::mutex> lock(done_mutex_);
      done.swap(done_);
    }
    for (const device::RunResult& r : done) {
      json ev = {
          {"event", "run_done"},
          {"run_id", r.run_id},
          {"fault", r.fault == rt::Fault::kNone ? json(nullptr) : json(rt::to_string(r.fault))},
          {"stopped", r.stopped},
          {"rows", r.rows},
          {"dropped_rows", r.dropped_rows},
          {"timing", device::timing_json<json>(r.timing)}};
      if (!r.dir.empty()) ev["record"] = r.dir.string();
      if (!r.recording_error.empty()) ev["recording_error"] = r.recording_error;
      spdlog::info("{}", r.brief_report());
      const auto it = owner_.find(r.run_id);
      if (it != owner_.end()) {
        if (Client* c = find(it->second)) reply(*c, ev);
        owner_.erase(it);  // a run's owner stays until its result: the daemon is busy till then
      }
    }
  }

  void stream_states() {
    rt::TickRecord rec;
    if (runner_.latest(rec)) latest_ = rec;
    const auto now = Clock::now();
    for (Client& c : clients_) {
      if (c.stream_hz <= 0.0 || now < c.next_state) continue;
      (void)send_line(c, state_json(latest_));  // a slow client misses states, nothing more
      c.next_state += std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(1.0 / c.stream_hz));
      if (c.next_state < now) c.next_state = now;
    }
  }

  void drop_closed() {
    for (auto it = clients_.begin(); it != clients_.end();) {
      if (it->close_after_write) {
        close(it->fd);
        it = clients_.erase(it);
      } else {
        ++it;
      }
    }
  }

  const Options& opt_;
  device::LoopRunner& runner_;
  const LoopSetup& setup_;
  const std::atomic<bool>& stop_;
  std::atomic<bool> realtime_{false};  ///< the loop thread got SCHED_FIFO
  std::vector<Client> clients_;
  std::map<std::uint32_t, int> owner_;  ///< runs posted and not finished → the client's fd
  std::uint32_t last_run_id_ = 0;
  std::mutex done_mutex_;
  std::deque<device::RunResult> done_;
  rt::TickRecord latest_;
};

}  // namespace

int connect_daemon(const std::string& path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof addr.sun_path) return -1;
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

ExitCode run_daemon(const Options& opt, std::atomic<bool>& stop) {
  auto logger = spdlog::stderr_color_mt("omni_ctl");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("omni_ctl[%P] %l: %v");
  LoopSetup setup;
  try {
    setup = make_loop_setup(opt);
  } catch (const Error& e) {
    spdlog::error("{}", e.what());
    return ExitCode::kBadInput;
  }
  if (!setup.model_note.empty()) spdlog::warn("{}", setup.model_note);
  device::Transport& transport = *setup.transport;
  int listen_fd = -1;
  try {
    listen_fd = listen_on(opt.socket_path);
  } catch (const Error& e) {
    spdlog::error("{}", e.what());
    return ExitCode::kDevice;
  }
  try {
    transport.open();
  } catch (const Error& e) {
    spdlog::error("{}", e.what());
    close(listen_fd);
    unlink(opt.socket_path.c_str());
    return ExitCode::kDevice;
  }

  std::unique_ptr<Server> server;
  device::LoopRunnerOptions ro;
  ro.on_run_done = [&server](const device::RunResult& r) {
    if (server) server->on_run_done(r);
  };
  device::LoopRunner runner(transport, setup.config, ro);
  server = std::make_unique<Server>(opt, runner, setup, stop);

  std::atomic<bool> loop_running{true};
  device::LoopOutcome outcome;
  std::thread loop_thread([&] {
    const auto rt_setup = device::request_realtime(opt.rt_priority, !opt.no_mlock);
    server->set_realtime(rt_setup.fifo);
    for (const auto& w : rt_setup.warnings) spdlog::warn("{}", w);
    spdlog::info("loop at {} Hz on {}, kp {}, max command {} V, socket {}; {}",
                 1.0 / setup.config.period_s, transport.describe(), setup.config.kp,
                 setup.config.safety.max_command_v, opt.socket_path, rt_setup.describe());
    outcome = runner.run(stop);
    loop_running.store(false);
  });
  server->serve(listen_fd, loop_running);
  stop.store(true);  // the server ended (signal or loop end): stop the loop too
  loop_thread.join();
  transport.close();

  json end = {{"event", "daemon_exit"}, {"timing", device::timing_json<json>(outcome.timing)}};
  if (!outcome.usable()) {
    end["fault"] = rt::to_string(outcome.fault);
    spdlog::critical("{}", outcome.brief_report());
  } else {
    spdlog::info("{}", outcome.brief_report());
  }
  server->broadcast_end(end);
  close(listen_fd);
  unlink(opt.socket_path.c_str());
  spdlog::info("timing: {}", outcome.timing.to_text());
  return outcome.usable() ? ExitCode::kOk : ExitCode::kFailed;
}

ExitCode run_client(int fd, const Options& opt, const std::atomic<bool>& stop) {
  auto send_json = [fd](const json& j) {
    const std::string line = j.dump() + "\n";
    return send(fd, line.data(), line.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(line.size());
  };
  std::string buffer;
  // Reads one line (blocking, but wakes every 50 ms to notice a signal). Empty: connection gone.
  bool stop_sent = false;
  auto read_line = [&](json& out) -> bool {
    for (;;) {
      const auto nl = buffer.find('\n');
      if (nl != std::string::npos) {
        const std::string line = buffer.substr(0, nl);
        buffer.erase(0, nl + 1);
        try {
          out = json::parse(line);
          return true;
        } catch (const json::exception&) {
          continue;
        }
      }
      if (stop.load() && !stop_sent) {
        stop_sent = true;
        send_json({{"cmd", "stop"}});
      }
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 50) <= 0) continue;
      char buf[4096];
      const ssize_t n = recv(fd, buf, sizeof buf, 0);
      if (n <= 0) return false;
      buffer.append(buf, static_cast<std::size_t>(n));
    }
  };
  auto expect_ok = [&](const char* what) {
    json r;
    while (read_line(r)) {
      if (r.contains("ok")) {
        if (!r["ok"].get<bool>()) {
          std::fprintf(stderr, "omni_ctl: daemon refused %s: %s\n", what,
                       r.value("error", std::string("?")).c_str());
          return false;
        }
        return true;
      }
    }
    std::fprintf(stderr, "omni_ctl: the daemon closed the connection\n");
    return false;
  };

  std::fprintf(stderr, "omni_ctl: using the daemon at %s\n", opt.socket_path.c_str());
  if (!send_json({{"cmd", "gains"}, {"kp", opt.kp}}) || !expect_ok("the gain")) {
    close(fd);
    return ExitCode::kBadInput;
  }
  json run = {{"cmd", "run"},
              {"waveform", wave_name(opt.wave.value())},
              {"amplitude_rad", opt.amplitude_rad},
              {"duration_s", opt.duration_s},
              {"command_line", opt.command_line}};
  if (is_periodic(*opt.wave)) run["freq_hz"] = opt.freq_hz;
  if (!opt.record_dir.empty()) run["record"] = fs::absolute(opt.record_dir).string();
  if (opt.force_record) run["force"] = true;
  if (!send_json(run) || !expect_ok("the run")) {
    close(fd);
    return ExitCode::kBadInput;
  }
  if (opt.stream_hz > 0.0) send_json({{"cmd", "stream"}, {"rate_hz", opt.stream_hz}});
  json ev;
  ExitCode code = ExitCode::kDevice;
  while (read_line(ev)) {
    const std::string kind = ev.value("event", std::string());
    if (kind == "state") {
      std::printf("%s\n", ev.dump().c_str());
      std::fflush(stdout);
    } else if (kind == "run_done") {
      std::fprintf(stderr, "omni_ctl: run done: %s\n", ev.dump().c_str());
      code = ExitCode::kOk;
      if (!ev["fault"].is_null()) code = ExitCode::kFailed;
      if (ev.contains("recording_error")) code = ExitCode::kRecording;
      break;
    } else if (kind == "daemon_exit") {
      std::fprintf(stderr, "omni_ctl: the daemon stopped: %s\n", ev.dump().c_str());
      code = ev.contains("fault") ? ExitCode::kFailed : ExitCode::kDevice;
      break;
    }
  }
  close(fd);
  return code;
}

}  // namespace omni_ctl

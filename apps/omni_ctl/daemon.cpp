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
#include <exception>
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
#include "protocol.hpp"
#include "socket.hpp"

namespace omni_ctl {
namespace {

using namespace alphainv;
using json = nlohmann::json;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

using protocol::error_reply;
using protocol::Request;
constexpr int kMaxClients = 16;

struct Client {
  int fd = -1;
  protocol::LineFramer in;  // bytes received, not yet a whole line
  double stream_hz = 0.0;   // 0: no state stream
  Clock::time_point next_state{};
  bool close_after_write = false;
};

/// Sends one JSON line (sanitised: protocol::to_line never throws) without blocking; false when
/// the client must be dropped.
bool send_line(Client& c, const json& j) {
  const std::string line = protocol::to_line(j);
  const ssize_t n = send(c.fd, line.data(), line.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  return n == static_cast<ssize_t>(line.size());
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
      : opt_(opt), runner_(runner), setup_(setup), stop_(stop) {
    if (pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) wake_[0] = wake_[1] = -1;
  }
  ~Server() {
    for (int fd : wake_) {
      if (fd >= 0) close(fd);
    }
  }
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// What the loop thread obtained: SCHED_FIFO or not (the `status` reply's `realtime`).
  void set_realtime(bool fifo) { realtime_.store(fifo); }

  void on_run_done(const device::RunResult& r) {
    {
      std::lock_guard<std::mutex> lock(done_mutex_);
      done_.push_back(r);
    }
    // Wake serve()'s poll, so the result goes out now rather than at its next timeout.
    const char byte = 1;
    if (wake_[1] >= 0) (void)!write(wake_[1], &byte, 1);
  }

  /// Serves until `loop_running` turns false or a stop is requested.
  void serve(int listen_fd, const std::atomic<bool>& loop_running) {
    while (loop_running.load() && !stop_.load()) {
      std::vector<pollfd> fds;
      fds.push_back({listen_fd, POLLIN, 0});
      fds.push_back({wake_[0], POLLIN, 0});  // a run finished (poll ignores fd −1)
      for (const Client& c : clients_) fds.push_back({c.fd, POLLIN, 0});
      const int timeout_ms = next_timeout_ms();
      const int n = poll(fds.data(), fds.size(), timeout_ms);
      if (n < 0 && errno != EINTR) {
        spdlog::error("poll: {}", std::strerror(errno));
        break;
      }
      if (n > 0 && (fds[0].revents & POLLIN)) accept_clients(listen_fd);
      if (n > 0 && (fds[1].revents & POLLIN)) {
        char drain[64];
        while (read(wake_[0], drain, sizeof drain) > 0) {
        }
      }
      for (std::size_t i = 2; i < fds.size(); ++i) {
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
      std::string line;
      std::size_t length = 0;
      for (;;) {
        const auto next = c->in.next(line, length);
        if (next == protocol::LineFramer::Next::kNone) break;
        if (next == protocol::LineFramer::Next::kTooLong) {
          reply(*c, error_reply("message too long: " + std::to_string(length) +
                                " bytes, the limit is " +
                                std::to_string(protocol::kMaxMessageBytes)));
          continue;
        }
        if (next == protocol::LineFramer::Next::kOverflow) {
          // No newline within the limit: answer once, then drop the connection.
          reply(*c, error_reply("message too long: no newline within " +
                                std::to_string(protocol::kMaxMessageBytes) + " bytes; closing"));
          c->close_after_write = true;
          return;
        }
        handle(*c, line);
      }
    }
  }

  void reply(Client& c, const json& j) {
    if (!send_line(c, j)) c.close_after_write = true;
  }

  void handle(Client& c, const std::string& line) {
    protocol::RequestLimits limits;
    limits.kp_max = runner_.config().kp_max;
    const protocol::ParsedRequest parsed = protocol::parse_request(line, limits);
    if (!parsed.request) {
      reply(c, error_reply(parsed.error));
      return;
    }
    const Request& r = *parsed.request;
    try {
      switch (r.cmd) {
        case Request::Cmd::kStatus:
          reply(c, status_reply());
          break;
        case Request::Cmd::kGains: {
          device::LoopCommand lc;
          lc.kind = device::LoopCommand::Kind::kSetKp;
          lc.kp = r.kp;
          if (!runner_.post(lc)) throw Error("the loop's command queue is full; retry");
          reply(c, {{"ok", true}, {"cmd", "gains"}, {"kp", r.kp}});
          break;
        }
        case Request::Cmd::kStream:
          c.stream_hz = r.rate_hz;
          c.next_state = Clock::now();
          reply(c, {{"ok", true}, {"cmd", "stream"}, {"rate_hz", c.stream_hz}});
          break;
        case Request::Cmd::kStop: {
          device::LoopCommand lc;
          lc.kind = device::LoopCommand::Kind::kStop;
          if (!runner_.post(lc)) throw Error("the loop's command queue is full; retry");
          reply(c, {{"ok", true}, {"cmd", "stop"}});
          break;
        }
        case Request::Cmd::kRun:
          start_run(c, r);
          break;
      }
    } catch (const std::exception& e) {  // alphainv::Error, and anything a bug would throw
      reply(c, error_reply(e.what()));
    }
  }

  json status_reply() const {
    const rt::SafetyLimits& s = runner_.config().safety;
    return {{"ok", true},
            {"cmd", "status"},
            {"kp", runner_.kp()},
            {"running", runner_.running_waveform()},
            {"ticks", runner_.ticks()},
            {"deadline_misses", runner_.deadline_misses()},
            {"realtime", realtime_.load()},
            {"device", setup_.transport->describe()},
            {"model", setup_.model_source},
            {"max_command_v", s.max_command_v},
            {"max_slew_v_per_s", s.max_slew_v_per_s},
            {"theta_limit_rad", s.theta_limit_rad},
            {"stall_periods", s.stall_periods},
            {"max_missed", s.max_missed_deadlines},
            {"kp_max", runner_.config().kp_max}};
  }

  void start_run(Client& c, const Request& r) {
    if (!owner_.empty() || runner_.running_waveform()) {
      throw Error("a run is in progress; send stop first", {}, 0, "cmd");
    }
    // The waveform is centred on the angle now (the loop holds it while idle): refuse a
    // reference the angle limit would end with a fault.
    rt::TickRecord now;
    if (runner_.latest(now)) latest_ = now;
    const std::string beyond = protocol::reference_beyond_limit(
        r.wave, r.amplitude_rad, latest_.theta_rad, runner_.config().safety.theta_limit_rad);
    if (!beyond.empty()) throw Error(beyond);
    Options o = opt_;
    o.wave = r.wave;
    o.freq_hz = r.freq_hz;
    o.amplitude_rad = r.amplitude_rad;
    o.duration_s = r.duration_s;
    o.record_dir = r.record;
    o.force_record = r.force;
    const std::uint32_t id = ++last_run_id_;
    const device::LoopCommand run = make_run_command(o, id);
    if (!o.record_dir.empty()) {
      o.command_line = !r.command_line.empty()
                           ? r.command_line
                           : std::string("omni_ctl --daemon: run ") + wave_name(r.wave);
      runner_.add_recording(id, make_recording(o, run, setup_));
    }
    if (!runner_.post(run)) throw Error("the loop's command queue is full; retry");
    owner_[id] = c.fd;
    spdlog::info("run {}: {} {} Hz, {} rad, {} s{}", id, wave_name(r.wave), o.freq_hz,
                 o.amplitude_rad, o.duration_s,
                 o.record_dir.empty() ? "" : ", recording to " + o.record_dir);
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
  int wake_[2] = {-1, -1};  ///< self-pipe: the writer thread wakes serve() when a run is done
  rt::TickRecord latest_;
};

}  // namespace

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
  SocketLock lock;  // one daemon per socket, held until this function returns
  Listener listener;
  try {
    listener = listen_on(opt.socket_path, lock);
  } catch (const std::exception& e) {  // alphainv::Error, std::filesystem::filesystem_error
    spdlog::error("{}", e.what());
    return ExitCode::kDevice;
  }
  try {
    transport.open();
  } catch (const Error& e) {
    spdlog::error("{}", e.what());
    listener.close_and_unlink();
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
  try {
    server->serve(listener.fd, loop_running);
  } catch (const std::exception& e) {  // a bug, not a client: end the loop safely, say why
    spdlog::critical("the server failed ({}); stopping the loop", e.what());
  }
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
  listener.close_and_unlink();
  spdlog::info("timing: {}", outcome.timing.to_text());
  return outcome.usable() ? ExitCode::kOk : ExitCode::kFailed;
}

namespace {

/// The daemon's value of loop option `name` in its status reply (as text), or empty when the
/// client cannot compare it (device, faults, scheduling: the daemon's own, always refused).
std::string daemon_value(const json& status, const std::string& name) {
  static const std::map<std::string, const char*> keys = {
      {"--max-command", "max_command_v"},    {"--max-slew", "max_slew_v_per_s"},
      {"--theta-limit", "theta_limit_rad"},  {"--stall-periods", "stall_periods"},
      {"--max-missed", "max_missed"},        {"--model", "model"}};
  const auto it = keys.find(name);
  if (it == keys.end() || !status.contains(it->second)) return {};
  const json& v = status[it->second];
  if (v.is_string()) return v.get<std::string>();
  return v.is_number() ? v.dump() : std::string();  // dumping a number cannot throw
}

/// This client's value of loop option `name`, as the daemon's status would spell it.
std::string client_value(const Options& opt, const std::string& name) {
  const rt::SafetyLimits& s = opt.safety;
  const auto num = [](auto x) { return json(x).dump(); };
  if (name == "--max-command") return num(s.max_command_v);
  if (name == "--max-slew") return num(s.max_slew_v_per_s);
  if (name == "--theta-limit") return num(s.theta_limit_rad);
  if (name == "--stall-periods") return num(s.stall_periods);
  if (name == "--max-missed") return num(s.max_missed_deadlines);
  if (name == "--model") return opt.model_path;
  return {};
}

/// Why the daemon cannot honour the loop options this client was given, or empty.
std::string unhonoured_options(const Options& opt, const json& status) {
  std::string out;
  for (const std::string& name : opt.loop_options_given) {
    const std::string theirs = daemon_value(status, name);
    const std::string ours = client_value(opt, name);
    if (!theirs.empty() && theirs == ours) continue;  // the daemon runs with just this value
    if (!out.empty()) out += ", ";
    out += name + (ours.empty() ? "" : " " + ours) +
           (theirs.empty() ? " (the daemon's own)" : " (the daemon uses " + theirs + ")");
  }
  return out;
}

}  // namespace

ExitCode run_client(int fd, const Options& opt, const std::atomic<bool>& stop) {
  using Steady = std::chrono::steady_clock;
  auto send_json = [fd](const json& j) {
    const std::string line = protocol::to_line(j);
    return send(fd, line.data(), line.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(line.size());
  };
  auto leave = [fd](ExitCode code) {
    close(fd);
    return code;
  };
  enum class Read { kLine, kClosed, kCancelled, kNoAnswer };
  std::string buffer;
  bool run_sent = false;  // from then on a signal sends stop instead of leaving
  bool stop_sent = false;
  Steady::time_point stop_deadline{};
  // Reads one JSON line, waking every 50 ms to notice a signal: before the run was sent, a signal
  // cancels at once (nothing was started); after, it sends stop and waits at most 3 s.
  auto read_line = [&](json& out) -> Read {
    for (;;) {
      const auto nl = buffer.find('\n');
      if (nl != std::string::npos) {
        const std::string line = buffer.substr(0, nl);
        buffer.erase(0, nl + 1);
        try {
          out = json::parse(line);
          if (out.is_object()) return Read::kLine;
        } catch (const json::exception&) {
        }
        continue;
      }
      if (stop.load()) {
        if (!run_sent) return Read::kCancelled;
        if (!stop_sent) {
          stop_sent = true;
          stop_deadline = Steady::now() + std::chrono::seconds(3);
          (void)send_json({{"cmd", "stop"}});
        } else if (Steady::now() > stop_deadline) {
          return Read::kNoAnswer;
        }
      }
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 50) <= 0) continue;
      char buf[4096];
      const ssize_t n = recv(fd, buf, sizeof buf, 0);
      if (n <= 0) return Read::kClosed;
      buffer.append(buf, static_cast<std::size_t>(n));
    }
  };
  auto say_why = [&](Read why) {
    if (why == Read::kCancelled) {
      std::fprintf(stderr, "omni_ctl: cancelled before the run was sent; nothing was started\n");
      return ExitCode::kOk;
    }
    if (why == Read::kNoAnswer) {
      std::fprintf(stderr,
                   "omni_ctl: the daemon did not answer the stop within 3 s; the stop request is "
                   "queued and ends the run as soon as the daemon reads it\n");
    } else {
      std::fprintf(stderr, "omni_ctl: the daemon closed the connection\n");
    }
    return ExitCode::kDevice;
  };
  // The reply to a request: true with `reply` when ok; else the exit code in `code`.
  auto expect_ok = [&](const char* what, json& reply, ExitCode& code) {
    for (;;) {
      const Read got = read_line(reply);
      if (got != Read::kLine) {
        code = say_why(got);
        return false;
      }
      if (!reply.contains("ok")) continue;  // an event
      if (reply["ok"] == true) return true;
      const json& err = reply.contains("error") ? reply["error"] : json("?");
      std::fprintf(stderr, "omni_ctl: the daemon refused %s: %s\n", what,
                   err.is_string() ? err.get<std::string>().c_str() : protocol::to_line(err).c_str());
      code = ExitCode::kBadInput;
      return false;
    }
  };

  std::fprintf(stderr, "omni_ctl: using the daemon at %s\n", opt.socket_path.c_str());
  json reply;
  ExitCode code = ExitCode::kOk;
  if (!send_json({{"cmd", "status"}}) || !expect_ok("the status request", reply, code)) {
    return leave(code);
  }
  if (const std::string why = unhonoured_options(opt, reply); !why.empty()) {
    std::fprintf(stderr,
                 "omni_ctl: the daemon at %s runs the loop with its own settings and cannot "
                 "honour: %s; stop the daemon, or run here with --local\n",
                 opt.socket_path.c_str(), why.c_str());
    return leave(ExitCode::kBadInput);
  }
  if (!send_json({{"cmd", "gains"}, {"kp", opt.kp}}) || !expect_ok("the gain", reply, code)) {
    return leave(code);
  }
  json run = {{"cmd", "run"},
              {"waveform", wave_name(opt.wave.value())},
              {"amplitude_rad", opt.amplitude_rad},
              {"duration_s", opt.duration_s},
              {"command_line", opt.command_line}};
  if (is_periodic(*opt.wave)) run["freq_hz"] = opt.freq_hz;
  if (!opt.record_dir.empty()) run["record"] = fs::absolute(opt.record_dir).string();
  if (opt.force_record) run["force"] = true;
  if (stop.load()) return leave(say_why(Read::kCancelled));
  run_sent = true;
  if (!send_json(run) || !expect_ok("the run", reply, code)) return leave(code);
  if (opt.stream_hz > 0.0) (void)send_json({{"cmd", "stream"}, {"rate_hz", opt.stream_hz}});
  json ev;
  for (;;) {
    const Read got = read_line(ev);
    if (got != Read::kLine) return leave(say_why(got));
    const json kind = ev.contains("event") ? ev["event"] : json();
    if (kind == "state") {
      std::printf("%s", protocol::to_line(ev).c_str());
      std::fflush(stdout);
    } else if (kind == "run_done") {
      std::fprintf(stderr, "omni_ctl: run done: %s", protocol::to_line(ev).c_str());
      code = ExitCode::kOk;
      if (ev.contains("fault") && !ev["fault"].is_null()) code = ExitCode::kFailed;
      if (ev.contains("recording_error")) code = ExitCode::kRecording;
      return leave(code);
    } else if (kind == "daemon_exit") {
      std::fprintf(stderr, "omni_ctl: the daemon stopped: %s", protocol::to_line(ev).c_str());
      return leave(ev.contains("fault") ? ExitCode::kFailed : ExitCode::kDevice);
    }
  }
}

}  // namespace omni_ctl

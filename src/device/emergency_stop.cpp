#include "alphainv/device/emergency_stop.hpp"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <exception>

namespace alphainv::device {
namespace {

std::atomic<Transport*> g_armed{nullptr};
std::atomic<std::uint16_t> g_next_sequence{0};
static_assert(std::atomic<Transport*>::is_always_lock_free, "the crash handler needs lock-free");
static_assert(std::atomic<std::uint16_t>::is_always_lock_free, "the crash handler needs lock-free");

constexpr int kFatalSignals[] = {SIGSEGV, SIGABRT, SIGBUS, SIGFPE, SIGILL};

void write_stderr(const char* text) noexcept {
  std::size_t n = 0;
  while (text[n] != 0) ++n;
  ssize_t rc = write(STDERR_FILENO, text, n);
  (void)rc;
}

extern "C" void on_fatal_signal(int sig) {
  // Async-signal-safe only: atomics, the transport's write, write(2), raise.
  if (emergency_stop()) {
    write_stderr("omni_ctl: fatal signal: a zero, disabled report was sent to the device\n");
  }
  // SA_RESETHAND restored the default action: re-raise so the process ends as it would have.
  raise(sig);
}

[[noreturn]] void on_terminate() noexcept {
  if (emergency_stop()) {
    write_stderr("omni_ctl: std::terminate: a zero, disabled report was sent to the device\n");
  }
  std::abort();  // SIGABRT: its handler writes once more (harmless) and ends the process
}

}  // namespace

void arm_emergency_stop(Transport& transport, std::uint16_t next_sequence) noexcept {
  g_next_sequence.store(next_sequence, std::memory_order_relaxed);
  g_armed.store(&transport, std::memory_order_release);
}

void note_sequence(std::uint16_t sent) noexcept {
  g_next_sequence.store(static_cast<std::uint16_t>(sent + 1), std::memory_order_relaxed);
}

void disarm_emergency_stop() noexcept { g_armed.store(nullptr, std::memory_order_release); }

bool emergency_stop() noexcept {
  Transport* t = g_armed.load(std::memory_order_acquire);
  if (t == nullptr) return false;
  OutputReport report;  // dac 0, enable false
  report.sequence = g_next_sequence.load(std::memory_order_relaxed);
  note_sequence(report.sequence);
  return t->write(report) == IoStatus::kOk;
}

void install_crash_handlers() {
  static bool installed = false;
  if (installed) return;
  installed = true;
  std::set_terminate(on_terminate);
  // The main thread's alternate stack, so that a stack overflow (SIGSEGV on the guard page)
  // reaches the handler; kept for the process's life.
  static AlternateSignalStack main_stack;
  struct sigaction sa {};
  sa.sa_handler = on_fatal_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND | SA_ONSTACK | SA_NODEFER;
  for (int sig : kFatalSignals) (void)sigaction(sig, &sa, nullptr);
}

constexpr std::size_t kAltStackBytes = 64 * 1024;

AlternateSignalStack::AlternateSignalStack() : stack_(new char[kAltStackBytes]) {
  stack_t ss{};
  ss.ss_sp = stack_.get();
  ss.ss_size = kAltStackBytes;
  installed_ = sigaltstack(&ss, nullptr) == 0;
}

AlternateSignalStack::~AlternateSignalStack() {
  if (!installed_) return;
  stack_t ss{};
  ss.ss_flags = SS_DISABLE;
  (void)sigaltstack(&ss, nullptr);
}

}  // namespace alphainv::device

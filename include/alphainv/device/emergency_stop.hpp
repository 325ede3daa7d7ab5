#pragma once
/// \file device/emergency_stop.hpp
/// The last word to the device when the process dies: while a loop runs (LoopRunner::run arms it
/// with its transport), a crash — std::terminate, or a fatal signal SIGSEGV, SIGABRT, SIGBUS,
/// SIGFPE, SIGILL — first writes a zero, disabled output report through that transport, then
/// lets the process die as it would have (the signal re-raised with its default action).
///
/// What it guarantees and what it cannot (docs/omni_ctl.md, "Crash and security guarantees"):
/// - the handler is async-signal-safe as far as the transport's write() is: it takes no lock,
///   allocates nothing, and calls only the transport's write() on a report built on its own
///   stack (encode() is arithmetic). HidTransport's write is hidapi's hid_write, which on the
///   hidraw back end is one write(2) on the device's fd;
/// - it runs on an alternate signal stack (the main thread's, and the loop thread's while
///   LoopRunner::run runs), so a stack overflow there still reaches it;
/// - it cannot run on SIGKILL, a power cut or a kernel crash, nor when the crash corrupted the
///   transport object itself or happened inside the transport's own write (the report may then be
///   lost); for those the device's own watchdog (docs/hid-reports.md) zeroes the motor when output
///   reports stop arriving.

#include <cstdint>
#include <memory>

#include "alphainv/device/transport.hpp"

namespace alphainv::device {

/// Makes `transport` the one the crash handlers write to (replacing any other). `next_sequence`:
/// the sequence number for the emergency report (note_sequence() keeps it current). Real-time
/// safe (two atomic stores).
void arm_emergency_stop(Transport& transport, std::uint16_t next_sequence = 0) noexcept;
/// Records that the report with sequence `sent` went out, so an emergency report continues the
/// sequence. Real-time safe (one relaxed atomic store).
void note_sequence(std::uint16_t sent) noexcept;
/// The crash handlers write nothing from now on. Real-time safe.
void disarm_emergency_stop() noexcept;
/// Writes one zero, disabled output report through the armed transport; false when none is
/// armed or the write failed. Async-signal-safe (see the file comment).
bool emergency_stop() noexcept;
/// Installs std::set_terminate and the SIGSEGV, SIGABRT, SIGBUS, SIGFPE, SIGILL handlers (on an
/// alternate stack) that call emergency_stop() before the process ends. Call once, early, from
/// the main thread. Not real-time.
void install_crash_handlers();

/// An alternate signal stack for the calling thread while this object lives, so that a stack
/// overflow on that thread still reaches the crash handler (install_crash_handlers() gives the
/// main thread one). Not real-time: construct before the loop.
class AlternateSignalStack {
 public:
  AlternateSignalStack();
  ~AlternateSignalStack();
  AlternateSignalStack(const AlternateSignalStack&) = delete;
  AlternateSignalStack& operator=(const AlternateSignalStack&) = delete;

 private:
  std::unique_ptr<char[]> stack_;
  bool installed_ = false;
};

}  // namespace alphainv::device

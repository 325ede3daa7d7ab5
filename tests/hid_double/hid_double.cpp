// A test double of the hidapi C API (the hid_* functions HidTransport uses, and the enumeration
// pair), backed by the virtual Omni speaking the reports of docs/hid-reports.md
// (alphainv::device::VirtualDevice). Linked instead of libhidapi-hidraw into a test build of
// omni_ctl, so report encoding, timeouts and error paths run end to end in ctest.
//
// Configuration (read in hid_open / hid_open_path, never in the loop):
//   ALPHAINV_HID_DOUBLE_FAULT=KIND@SECONDS  inject a fault (disconnect, stall, corrupt, sequence,
//                                           encoder-jump, slow) at that device time
//   ALPHAINV_HID_DOUBLE_LOG=FILE            on hid_close, write every output report the device
//                                           saw as CSV: device_tick,sequence,dac_counts,enable,
//                                           decoded,delivered,fault_active
//   ALPHAINV_HID_DOUBLE_ABSENT=1            no device: hid_open fails
//   ALPHAINV_HID_DOUBLE_STATE=FILE          keep the last output report (HidDoubleState) in FILE,
//                                           mapped MAP_SHARED: it survives a crash of the process
//   ALPHAINV_HID_DOUBLE_CRASH=KIND@SECONDS  crash the process inside hid_read at that device time,
//                                           as a bug would: KIND = terminate (an exception out of
//                                           the noexcept read), segv, abort, bus, fpe, ill (the
//                                           signal raised)
// The device answers to VID:PID 1209:0001 or the path /dev/hidraw-double.
#include <fcntl.h>
#include <hidapi/hidapi.h>
#include <signal.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include <stdexcept>

#include "alphainv/device/sim_transport.hpp"
#include "hid_double_state.hpp"

using alphainv::test::HidDoubleState;

struct hid_device_ {
  std::unique_ptr<alphainv::device::VirtualDevice> device;
  std::string log_path;
  bool nonblocking = false;
  HidDoubleState* state = nullptr;  // mapped, or null
  int crash_signal = 0;             // 0: none; -1: std::terminate
  double crash_at_s = 0.0;
};

namespace {

const wchar_t* g_error = L"";

HidDoubleState* map_state(const char* path) {
  const int fd = open(path, O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return nullptr;
  void* p = nullptr;
  if (ftruncate(fd, sizeof(HidDoubleState)) == 0) {
    p = mmap(nullptr, sizeof(HidDoubleState), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  }
  close(fd);
  if (p == MAP_FAILED || p == nullptr) return nullptr;
  auto* state = new (p) HidDoubleState;
  state->magic = HidDoubleState::kMagic;
  return state;
}

/// "KIND@SECONDS" of ALPHAINV_HID_DOUBLE_CRASH; false when malformed.
bool parse_crash(const char* text, int& signal_out, double& at_s) {
  const char* at = std::strchr(text, '@');
  if (at == nullptr) return false;
  const std::string kind(text, at);
  const struct {
    const char* name;
    int sig;
  } kinds[] = {{"terminate", -1}, {"segv", SIGSEGV}, {"abort", SIGABRT},
               {"bus", SIGBUS},   {"fpe", SIGFPE},   {"ill", SIGILL}};
  signal_out = 0;
  for (const auto& k : kinds) {
    if (kind == k.name) signal_out = k.sig;
  }
  char* end = nullptr;
  at_s = std::strtod(at + 1, &end);
  return signal_out != 0 && end != at + 1;
}

hid_device* open_double() {
  const char* absent = std::getenv("ALPHAINV_HID_DOUBLE_ABSENT");
  if (absent != nullptr && std::strcmp(absent, "1") == 0) {
    g_error = L"hid double: no such device (ALPHAINV_HID_DOUBLE_ABSENT=1)";
    return nullptr;
  }
  alphainv::device::SimFault fault;
  if (const char* f = std::getenv("ALPHAINV_HID_DOUBLE_FAULT"); f != nullptr && *f != 0) {
    try {
      fault = alphainv::device::parse_sim_fault(f, "ALPHAINV_HID_DOUBLE_FAULT");
    } catch (const std::exception& e) {
      std::fprintf(stderr, "hid double: %s\n", e.what());
      g_error = L"hid double: bad ALPHAINV_HID_DOUBLE_FAULT";
      return nullptr;
    }
  }
  auto* dev = new hid_device_;
  dev->device = std::make_unique<alphainv::device::VirtualDevice>(
      alphainv::VirtualOmniParams{}, alphainv::device::ReportScaling{}, fault, 1 << 16);
  if (const char* log = std::getenv("ALPHAINV_HID_DOUBLE_LOG")) dev->log_path = log;
  if (const char* st = std::getenv("ALPHAINV_HID_DOUBLE_STATE"); st != nullptr && *st != 0) {
    dev->state = map_state(st);
  }
  if (const char* c = std::getenv("ALPHAINV_HID_DOUBLE_CRASH"); c != nullptr && *c != 0) {
    if (!parse_crash(c, dev->crash_signal, dev->crash_at_s)) {
      std::fprintf(stderr, "hid double: bad ALPHAINV_HID_DOUBLE_CRASH '%s'\n", c);
      delete dev;
      g_error = L"hid double: bad ALPHAINV_HID_DOUBLE_CRASH";
      return nullptr;
    }
  }
  g_error = L"";
  return dev;
}

}  // namespace

extern "C" {

int HID_API_EXPORT HID_API_CALL hid_init(void) { return 0; }
int HID_API_EXPORT HID_API_CALL hid_exit(void) { return 0; }

struct hid_device_info HID_API_EXPORT* HID_API_CALL hid_enumerate(unsigned short vendor_id,
                                                                  unsigned short product_id) {
  if ((vendor_id != 0 && vendor_id != 0x1209) || (product_id != 0 && product_id != 0x0001)) {
    return nullptr;
  }
  auto* info = static_cast<hid_device_info*>(std::calloc(1, sizeof(hid_device_info)));
  info->path = strdup("/dev/hidraw-double");
  info->vendor_id = 0x1209;
  info->product_id = 0x0001;
  return info;
}

void HID_API_EXPORT HID_API_CALL hid_free_enumeration(struct hid_device_info* devs) {
  while (devs != nullptr) {
    hid_device_info* next = devs->next;
    std::free(devs->path);
    std::free(devs);
    devs = next;
  }
}

HID_API_EXPORT hid_device* HID_API_CALL hid_open(unsigned short vendor_id,
                                                 unsigned short product_id,
                                                 const wchar_t* /*serial_number*/) {
  if (vendor_id != 0x1209 || product_id != 0x0001) {
    g_error = L"hid double: no device with that VID:PID (the double is 1209:0001)";
    return nullptr;
  }
  return open_double();
}

HID_API_EXPORT hid_device* HID_API_CALL hid_open_path(const char* path) {
  if (path == nullptr || std::strcmp(path, "/dev/hidraw-double") != 0) {
    g_error = L"hid double: no such path (the double is /dev/hidraw-double)";
    return nullptr;
  }
  return open_double();
}

int HID_API_EXPORT HID_API_CALL hid_set_nonblocking(hid_device* dev, int nonblock) {
  dev->nonblocking = nonblock != 0;
  return 0;
}

int HID_API_EXPORT HID_API_CALL hid_write(hid_device* dev, const unsigned char* data,
                                          size_t length) {
  const int n = dev->device->write(data, length);
  if (n < 0) g_error = L"hid double: write failed, device disconnected (injected fault)";
  if (HidDoubleState* st = dev->state) {
    alphainv::device::OutputReport r;
    const bool ok = alphainv::device::decode(data, length, r) == alphainv::device::DecodeStatus::kOk;
    st->last_sequence = ok ? r.sequence : 0;
    st->last_dac = ok ? r.dac_counts : 0;
    st->last_enable = ok && r.enable ? 1 : 0;
    st->last_decoded = ok ? 1 : 0;
    st->enabled_writes += st->last_enable;
    st->watchdog_trips = static_cast<std::uint64_t>(dev->device->watchdog_trips());
    ++st->writes;  // last: a reader that sees the count sees the report
  }
  return n;
}

int HID_API_EXPORT HID_API_CALL hid_read_timeout(hid_device* dev, unsigned char* data,
                                                 size_t length, int /*milliseconds*/) {
  if (dev->crash_signal != 0 && dev->device->plant().time_s() >= dev->crash_at_s) {
    if (dev->crash_signal < 0) throw std::runtime_error("hid double: injected crash");
    raise(dev->crash_signal);
  }
  if (dev->device->slow()) {
    timespec ts{0, 3'000'000};
    nanosleep(&ts, nullptr);
  }
  const int n = dev->device->read(data, length);
  if (n < 0) g_error = L"hid double: read failed, device disconnected (injected fault)";
  return n;
}

int HID_API_EXPORT HID_API_CALL hid_read(hid_device* dev, unsigned char* data, size_t length) {
  return hid_read_timeout(dev, data, length, dev->nonblocking ? 0 : -1);
}

void HID_API_EXPORT HID_API_CALL hid_close(hid_device* dev) {
  if (dev == nullptr) return;
  if (!dev->log_path.empty()) {
    if (FILE* f = std::fopen(dev->log_path.c_str(), "w")) {
      std::fprintf(f, "device_tick,sequence,dac_counts,enable,decoded,delivered,fault_active\n");
      for (const auto& w : dev->device->written()) {
        std::fprintf(f, "%ld,%u,%d,%d,%d,%d,%d\n", w.device_tick, w.report.sequence,
                     w.report.dac_counts, w.report.enable ? 1 : 0, w.decoded ? 1 : 0,
                     w.delivered ? 1 : 0, w.fault_active ? 1 : 0);
      }
      std::fclose(f);
    }
  }
  if (dev->state != nullptr) munmap(dev->state, sizeof(HidDoubleState));
  delete dev;
}

HID_API_EXPORT const wchar_t* HID_API_CALL hid_error(hid_device* /*dev*/) { return g_error; }

}  // extern "C"

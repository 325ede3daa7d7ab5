#pragma once
// What the hidapi test double (hid_double.cpp) keeps of the output reports in a file mapped
// MAP_SHARED (ALPHAINV_HID_DOUBLE_STATE=FILE): updated at every hid_write, so it survives the
// process however it ends (a crash, SIGKILL) and a test reads what the device last received.
#include <cstdint>

namespace alphainv::test {

struct HidDoubleState {
  static constexpr std::uint64_t kMagic = 0x616c706861696e76ULL;  // "alphainv"
  std::uint64_t magic = 0;           ///< kMagic once the device was opened
  std::uint64_t writes = 0;          ///< output reports received
  std::uint64_t enabled_writes = 0;  ///< of which decoded with the enable bit set
  std::uint64_t watchdog_trips = 0;  ///< the device's watchdog trips so far
  std::uint16_t last_sequence = 0;   ///< the last report's sequence
  std::int16_t last_dac = 0;         ///< the last report's DAC counts (0 when it did not decode)
  std::uint8_t last_enable = 0;      ///< the last report's enable bit
  std::uint8_t last_decoded = 0;     ///< the last report decoded
  std::uint8_t pad[2] = {};
};

}  // namespace alphainv::test

// libFuzzer target: arbitrary frames, time steps and input changes into the drive simulator.
// Invariants: no crash (ASan/UBSan), every frame the drive sends is a well-formed reply on its
// current Tx ID (DLC 4 or 6, stuff byte 0x00), and time sliced differently gives the same frames.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "drive_sim/parameter_store.hpp"
#include "drive_sim/regid_protocol.hpp"
#include "drive_sim/unitek_drive.hpp"

namespace {

using namespace candp2;
using namespace candp2::drive;

// Checks every frame and folds it into a digest (FNV-1a), so long runs need no memory.
struct CheckingSink final : can::FrameSink {
  const UnitekDrive* drive = nullptr;
  std::uint64_t digest = 14695981039346656037ull;
  std::uint64_t count = 0;
  void send(const can::Frame& f) override {
    if (!is_well_formed_reply(f)) std::abort();
    if (drive && f.id != drive->tx_id()) std::abort();
    auto mix = [&](std::uint8_t b) { digest = (digest ^ b) * 1099511628211ull; };
    mix(static_cast<std::uint8_t>(f.id));
    mix(static_cast<std::uint8_t>(f.id >> 8));
    mix(f.dlc);
    for (std::uint8_t i = 0; i < f.dlc; ++i) mix(f.data[i]);
    ++count;
  }
};

struct Outcome {
  std::uint64_t digest;
  std::uint64_t count;
  friend bool operator==(const Outcome&, const Outcome&) = default;
};

class Input {
 public:
  Input(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return pos_ >= size_; }
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

// Runs the input against one drive; `slice_ms` > 0 advances in extra intermediate steps.
Outcome run(const std::uint8_t* data, std::size_t size, std::int64_t slice_ms) {
  UnitekDrive::Options o;
  o.reference_run_time = milliseconds(20);
  o.status_16bit = size > 0 && (data[0] & 1);
  MemoryParameterStore store;
  UnitekDrive drive(o, nullptr, &store);
  CheckingSink sink;
  sink.drive = &drive;
  Input in(data, size);
  Time now{0};
  while (!in.empty()) {
    const std::uint8_t op = in.byte();
    switch (op % 6) {
      case 0:
      case 1:
      case 2: {  // a frame, mostly on the drive's Rx ID
        can::Frame f;
        const std::uint8_t flags = in.byte();
        f.id = (flags & 0x80) ? ((std::uint32_t{in.byte()} << 8 | in.byte()) & can::kMaxStdId)
                              : drive.rx_id();
        f.extended = flags & 0x40;
        f.remote = flags & 0x20;
        f.dlc = flags & 0x0F;
        if (f.dlc > 8) f.dlc = 8;
        if (!f.remote)
          for (std::uint8_t i = 0; i < f.dlc; ++i) f.data[i] = in.byte();
        drive.on_frame(f, now, sink);
        break;
      }
      case 3: {  // time passes: up to 16 s
        const std::int64_t ms = std::int64_t{in.byte() & 0x3Fu} << 8 | in.byte();
        const Time end = now + milliseconds(ms);
        if (slice_ms > 0)
          while (now + milliseconds(slice_ms) < end) {
            now += milliseconds(slice_ms);
            drive.advance(now, sink);
          }
        now = end;
        drive.advance(now, sink);
        break;
      }
      case 4: {  // an input changes
        const std::uint8_t b = in.byte();
        switch (b % 5) {
          case 0:
            drive.set_enable_input(b & 0x80, now, sink);
            break;
          case 1:
            drive.set_limit_switch(LimitSwitch::Plus, b & 0x80, now, sink);
            break;
          case 2:
            drive.set_limit_switch(LimitSwitch::Minus, b & 0x80, now, sink);
            break;
          case 3:
            drive.set_power_ok(b & 0x80, now, sink);
            break;
          case 4:
            drive.set_errors(b & 0x80 ? b : 0, now, sink);
            break;
        }
        break;
      }
      case 5: {  // sub-millisecond step
        now += microseconds(in.byte() * 7);
        drive.advance(now, sink);
        break;
      }
    }
    if (const auto deadline = drive.next_deadline(); deadline && *deadline <= now)
      std::abort();  // a deadline not in the future after advance(): an event loop would spin
  }
  // What an EEPROM write stores parses back unchanged.
  const StoredParameters params = drive.parameters();
  const StateFileParse parsed = parse_state_file(format_state_file(params));
  if (!parsed.parameters || *parsed.parameters != params) std::abort();
  return {sink.digest, sink.count};
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 4096) return 0;
  const auto whole = run(data, size, 0);
  const auto sliced = run(data, size, 13);
  if (whole != sliced) std::abort();
  // The state file parser takes the same bytes as text: any answer but a crash is fine.
  (void)parse_state_file(std::string_view(reinterpret_cast<const char*>(data), size));
  return 0;
}

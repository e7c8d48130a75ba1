// Fuzzes the Communication Window: the write/read window decoders and the window state
// machine, alone and inside a whole gateway (CANopen master with a CW), driven by a byte script.
// Invariants: no crash or sanitizer report; encode(decode(w)) == w for write windows and for every
// read window decode accepts; every read window the gateway shows decodes; the FIFO never exceeds
// 255 frames; frames are conserved (enabled frames = delivered + queued + MSG_LOST); only valid CAN
// frames are transmitted; the read window echoes the last executed loop counter.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "gateway/comm_window.hpp"
#include "gateway/gateway.hpp"

using namespace candp2;

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

bool valid_frame(const can::Frame& f) {
  if (f.dlc > can::kMaxDlc) return false;
  if (f.id > (f.extended ? can::kMaxExtId : can::kMaxStdId)) return false;
  for (std::size_t i = f.remote ? 0 : f.dlc; i < f.data.size(); ++i)
    if (f.data[i] != 0) return false;
  return true;
}

struct Host : gw::CwHost {
  bool released = true;
  bool master = true;
  std::uint16_t sync_ms = 0;
  std::uint32_t sent = 0;
  bool tx_active() const override { return released; }
  void transmit(const can::Frame& f) override {
    check(valid_frame(f));
    ++sent;
  }
  bool can_released() const override { return released; }
  bool set_sync_time(std::uint16_t ms, Time) override {
    if (master) sync_ms = ms;
    return master;
  }
};

struct CheckingSink : can::FrameSink {
  void send(const can::Frame& f) override { check(valid_frame(f)); }
};

// Reads bytes from the script; past the end it yields zeros.
struct Script {
  std::span<const std::uint8_t> bytes;
  std::size_t pos = 0;
  bool done() const { return pos >= bytes.size(); }
  std::uint8_t u8() { return pos < bytes.size() ? bytes[pos++] : 0; }
  std::array<std::uint8_t, gw::kCwLen> window() {
    std::array<std::uint8_t, gw::kCwLen> w{};
    for (auto& b : w) b = u8();
    return w;
  }
  can::Frame frame() {
    // Identifiers from a small set so that enabled ones are hit often.
    const std::uint8_t sel = u8();
    can::Frame f;
    f.extended = sel & 0x80;
    f.remote = (sel & 0x40) && (sel & 0x01);
    f.id = (sel & 0x0F) | (f.extended ? (std::uint32_t{u8()} << 21) : 0x100u);
    f.dlc = static_cast<std::uint8_t>(u8() % 9);
    if (!f.remote)
      for (std::uint8_t i = 0; i < f.dlc; ++i) f.data[i] = u8();
    return f;
  }
};

void fuzz_wire(std::span<const std::uint8_t> data) {
  if (data.size() < gw::kCwLen) return;
  const auto w = data.first<gw::kCwLen>();
  const auto req = gw::decode_cw_request(w);
  const auto again = gw::encode_cw_request(req);
  check(std::equal(again.begin(), again.end(), w.begin()));
  if (auto id = req.identifier()) {
    std::array<std::uint8_t, 4> b{};
    gw::cw_encode_ident(*id, b);
    check(std::equal(b.begin(), b.end(), req.ident.begin()));
  }
  if (auto reply = gw::decode_cw_reply(w)) {
    const auto bytes = gw::encode_cw_reply(*reply);
    check(std::equal(bytes.begin(), bytes.end(), w.begin()));
    if (reply->frame) check(valid_frame(*reply->frame));
  }
}

void fuzz_window(std::span<const std::uint8_t> data) {
  Script s{data};
  Host host;
  gw::CommWindow cw;
  std::uint8_t last_counter = 0;
  std::uint64_t enabled_frames = 0, delivered = 0;
  Time now{0};
  while (!s.done()) {
    const std::uint8_t op = s.u8();
    switch (op % 4) {
      case 0: {
        const auto w = s.window();
        const bool was_armed = cw.read_armed();
        const std::size_t level = cw.fifo_level();
        cw.on_write(w, now, host);
        if (w[gw::kCwCounter] != last_counter) {
          last_counter = w[gw::kCwCounter];
          check(cw.reply().counter == last_counter);
          check(cw.reply().sub_command == w[gw::kCwSubCommand]);
          check(cw.reply().error <= gw::kCwErrNotReleased);
          // A command 3 that found the FIFO non-empty delivered its oldest frame.
          if (w[gw::kCwCommand] == gw::kCwRead && level > 0) {
            check(cw.reply().frame.has_value() && cw.fifo_level() == level - 1);
            ++delivered;
          }
        } else {
          check(cw.read_armed() == was_armed && cw.fifo_level() == level);
        }
        break;
      }
      case 1: {
        const auto f = s.frame();
        const bool armed = cw.read_armed();
        const bool enabled = !f.remote && cw.is_enabled(can::ident_of(f));
        check(cw.on_frame(f) == enabled);
        if (enabled) {
          ++enabled_frames;
          if (armed) {
            ++delivered;
            check(!cw.read_armed() && cw.reply().frame == f);
          }
        }
        break;
      }
      case 2:
        host.released = s.u8() & 1;
        host.master = s.u8() & 1;
        break;
      case 3:
        now += milliseconds(s.u8());
        break;
    }
    check(cw.fifo_level() <= gw::kCwFifoCapacity);
    check(cw.fifo_high_water() >= cw.fifo_level());
    check(enabled_frames == delivered + cw.fifo_level() + cw.msg_lost());
    std::array<std::uint8_t, gw::kCwLen> read{};
    cw.read(read);
    const auto reply = gw::decode_cw_reply(read);
    check(reply.has_value() && *reply == cw.reply());
  }
}

void fuzz_gateway(std::span<const std::uint8_t> data) {
  // A CANopen master with a CW and one Rx slot, SYNC from the script; windows through DP.
  Script s{data};
  CheckingSink sink;
  Time now{0};
  gw::Gateway g({.address = 3}, sink, now);
  gw::UserPrm p;
  p.comm_window = true;
  p.canopen_master = true;
  p.start_frame = s.u8() & 1;
  p.wakeup_s = s.u8() % 3;
  p.sync_ms = static_cast<std::uint16_t>(s.u8() % 50);
  p.can_diagnosis = true;
  g.dp().set_prm(1, gw::make_set_prm(p), now);
  const auto cfg = dp::encode_chk_cfg(
      std::vector<dp::CfgEntry>{dp::special_input(2, true, {0x01, 0x01, 0x00}),
                                dp::special_input(16, true, {0xFF, 0xEF, 0x00, 0x00, 0x0A}),
                                dp::special_output(16, true, {0xFF, 0xEF, 0x00})});
  g.dp().chk_cfg(1, cfg, now);
  check(g.dp().state() == dp::SlaveState::DataExch);
  while (!s.done()) {
    const std::uint8_t op = s.u8();
    switch (op % 3) {
      case 0: {
        const auto w = s.window();
        auto in = g.dp().data_exchange(1, w, now);
        check(in.has_value() && in->size() == 18);
        check(gw::decode_cw_reply(in->subspan(2).first<gw::kCwLen>()).has_value());
        break;
      }
      case 1:
        g.on_can_frame(s.frame(), now);
        break;
      case 2: {
        now += microseconds(std::uint32_t{s.u8()} * 977);
        // Fire every timer on the way, as the daemon does.
        for (int guard = 0; guard < 100000; ++guard) {
          const auto d = g.next_deadline();
          if (!d || *d > now) break;
          g.advance(*d);
        }
        g.advance(now);
        const auto d = g.next_deadline();
        check(!d || *d > now);  // every deadline announced was served
        break;
      }
    }
    check(g.status().fifo_level <= gw::kCwFifoCapacity);
    const auto diag = g.dp().slave_diag(now);
    check(diag[10] == std::min<std::uint32_t>(g.status().msg_lost, 255));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  fuzz_wire(bytes);
  fuzz_window(bytes);
  fuzz_gateway(bytes);
  return 0;
}

// Test fixture for the gateway core: a Gateway on a recording frame sink, a simulated master
// address, an injected clock. Frames are compared in candump notation, readable in a failure.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "can/frame.hpp"
#include "common/hex.hpp"
#include "gateway/gateway.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::gw::test {

inline constexpr std::uint8_t kMaster = 1;

struct Recorder : can::FrameSink {
  struct Sent {
    Time time;
    can::Frame frame;
  };
  void send(const can::Frame& f) override { sent.push_back({*now, f}); }
  // All frames sent so far in candump notation; clears the record.
  std::vector<std::string> take() {
    std::vector<std::string> out;
    for (const auto& s : sent) out.push_back(can::format_candump(s.frame));
    sent.clear();
    return out;
  }
  std::vector<Sent> sent;
  const Time* now = nullptr;
};

inline can::Frame F(const char* text) {
  auto r = can::parse_candump(text);
  EXPECT_TRUE(r) << text << ": " << r.error.message;
  return r.frame.value_or(can::Frame{});
}

inline std::vector<std::string> V(std::initializer_list<const char*> frames) {
  return {frames.begin(), frames.end()};
}

inline std::string hex(std::span<const std::uint8_t> b) {
  return hex_bytes(b);
}

class GatewayFixture : public ::testing::Test {
 protected:
  GatewayFixture() { rec.now = &now; }

  void make(GatewayOptions o = {}) { gw = std::make_unique<Gateway>(o, rec, now); }
  // Set_Prm + Chk_Cfg; returns true when the gateway reached Data_Exch.
  bool configure(const UserPrm& p, std::vector<std::uint8_t> cfg, std::uint16_t watchdog_ms = 0) {
    if (!gw) make();
    // A class 1 master parameterizes with Lock_Req (docs/dp-slave.md "Lock").
    const auto prm = dp::with_lock_req(make_set_prm(p, watchdog_ms));
    gw->dp().set_prm(kMaster, prm, now);
    gw->dp().chk_cfg(kMaster, cfg, now);
    return gw->dp().state() == dp::SlaveState::DataExch;
  }
  // One Data_Exchange; returns the input image.
  std::vector<std::uint8_t> exchange(std::vector<std::uint8_t> outputs) {
    auto in = gw->dp().data_exchange(kMaster, outputs, now);
    EXPECT_TRUE(in.has_value()) << "Data_Exchange refused";
    return in ? std::vector<std::uint8_t>(in->begin(), in->end()) : std::vector<std::uint8_t>{};
  }
  void rx(const char* frame) { gw->on_can_frame(F(frame), now); }
  // Advances the clock to `t`, firing every timer on the way in order.
  void run_until(Time t) {
    while (true) {
      auto d = gw->next_deadline();
      if (!d || *d > t) break;
      now = std::max(now, *d);
      gw->advance(now);
    }
    now = t;
    gw->advance(now);
  }
  void run_for(Duration d) { run_until(now + d); }
  std::array<std::uint8_t, 11> diag() { return gw->dp().slave_diag(now); }

  Time now{0};
  Recorder rec;
  std::unique_ptr<Gateway> gw;
};

// Chk_Cfg builders in the special identifier format (manual §7, docs/slots.md "Chk_Cfg slots").
inline std::vector<std::uint8_t> cfg_of(std::initializer_list<dp::CfgEntry> entries) {
  std::vector<dp::CfgEntry> v(entries);
  return dp::encode_chk_cfg(v);
}
inline dp::CfgEntry in_slot(std::uint8_t len, std::vector<std::uint8_t> comment) {
  return dp::special_input(len, true, std::move(comment));
}
inline dp::CfgEntry out_slot(std::uint8_t len, std::vector<std::uint8_t> comment) {
  return dp::special_output(len, true, std::move(comment));
}
// The 0x07F8 dummy output (manual §5.1.4) for configurations that need no real output.
inline dp::CfgEntry dummy_out() {
  return out_slot(1, {0x07, 0xF8, 0x00});
}

}  // namespace candp2::gw::test

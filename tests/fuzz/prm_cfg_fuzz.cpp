// Fuzzes the Set_Prm and Chk_Cfg decoders and a whole gateway fed with them.
// Invariants: no crash or sanitizer report; a fault always names a byte inside the telegram or a
// slot inside the configuration; an accepted configuration respects the manual's limits; Chk_Cfg
// identifier bytes survive an encode/decode round trip.
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "gateway/gateway.hpp"

using namespace candp2;

namespace {
struct NullSink : can::FrameSink {
  void send(const can::Frame&) override {}
};
void check(bool ok) {
  if (!ok) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 16) return 0;
  const std::span<const std::uint8_t> prm(data, 16);
  const std::span<const std::uint8_t> cfg(data + 16, size - 16);

  auto user = gw::decode_user_prm(prm);
  if (auto* f = std::get_if<dp::PrmFault>(&user)) check(f->byte < 16);

  auto entries = dp::decode_chk_cfg(cfg);
  if (!entries.error) {
    const auto again = dp::decode_chk_cfg(dp::encode_chk_cfg(entries.entries));
    check(!again.error && again.entries.size() == entries.entries.size());
  }

  gw::UserPrm p;
  if (auto* ok = std::get_if<gw::UserPrm>(&user)) p = *ok;
  auto slots = gw::decode_slots(cfg, p);
  if (auto* c = std::get_if<gw::SlotConfig>(&slots)) {
    check(c->slots.size() <= gw::kMaxSlots);
    check(c->input_len <= gw::kMaxInputLen && c->output_len <= gw::kMaxOutputLen);
    check(c->input_len + c->output_len <= gw::kMaxDataLen);
  } else {
    const auto& f = std::get<dp::CfgFault>(slots);
    check(f.code >= 1 && f.code <= 10);
  }

  // The same bytes through the DP services of a whole gateway, with a Data_Exchange and a frame.
  NullSink sink;
  gw::Gateway g({.address = 3}, sink, Time{0});
  std::vector<std::uint8_t> telegram(prm.begin(), prm.end());
  telegram[4] = 0x04;  // make the Ident right so the user bytes get checked
  telegram[5] = 0xA4;
  telegram[0] &=
      static_cast<std::uint8_t>(~dp::kPrmWdOn);  // the clock below jumps 5 s: no watchdog
  g.dp().set_prm(1, telegram, Time{0});
  g.dp().chk_cfg(1, cfg, Time{1000});
  const auto diag = g.dp().slave_diag(Time{2000});
  check(diag[4] == 0x04 && diag[5] == 0xA4);
  if (g.dp().state() == dp::SlaveState::DataExch) {
    std::vector<std::uint8_t> out(g.slot_config()->output_len, 0x5A);
    check(g.dp().data_exchange(1, out, Time{3000}).has_value());
    can::Frame f;
    f.id = cfg.empty() ? 0 : cfg[0];
    f.dlc = 8;
    g.on_can_frame(f, Time{4000});
    g.advance(Time{5000000});
    check(g.dp().data_exchange(1, out, Time{5000000}).has_value());
  }
  return 0;
}

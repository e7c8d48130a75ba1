// The shipped GSD's user parameters against the gateway core: every ExtUserPrmData set
// to each allowed value (ranges: min, max, default and a middle value) encodes through
// gsd::encode_user_prm to bytes gw::decode_user_prm accepts and decodes back to the same named
// value; flag combinations manual table 5.1.2 forbids give the Prm fault the gateway itself
// reports; and the GSD encoding of `candp2 validate --gsd` equals the built-in encoding of
// config::set_prm_bytes byte for byte (docs/dp-slave.md "User parameters").
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <variant>

#include "common/hex.hpp"
#include "config/config.hpp"
#include "gateway/gateway.hpp"
#include "gateway/line_limits.hpp"
#include "gateway/user_prm.hpp"
#include "gsd/gsd.hpp"
#include "gsd/prm.hpp"
#include "profibus_sim/fdl/line_timing.hpp"
#include "validate/params.hpp"

namespace candp2::validate {
namespace {

const gsd::Model& shipped() {
  static const gsd::ParseResult r = gsd::parse_file(CANDP2_SOURCE_DIR "/gsd/CDPS04A4.GSD");
  return r.model;
}

const ParamMapping& mapping(std::string_view gsd_name) {
  for (const auto& m : param_mappings())
    if (m.gsd_name == gsd_name) return m;
  throw std::runtime_error("no mapping for " + std::string(gsd_name));
}

// Set_Prm telegram: standard part with Ident 0x04A4 (gw::make_set_prm), then the user bytes.
std::vector<std::uint8_t> telegram(const std::vector<std::uint8_t>& user) {
  const auto t = gw::make_set_prm({});
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i < dp::kPrmStdLen; ++i) out.push_back(t[i]);
  for (const std::uint8_t b : user) out.push_back(b);
  return out;
}

std::vector<std::int64_t> values_of(const gsd::ExtUserPrmData& d) {
  if (!d.allowed.empty()) return d.allowed;
  const std::int64_t lo = *d.min, hi = *d.max;
  if (hi - lo < 16) {  // small ranges: every value (bit rates 0..13, bits 0..1)
    std::vector<std::int64_t> all;
    for (std::int64_t v = lo; v <= hi; ++v) all.push_back(v);
    return all;
  }
  return {lo, hi, d.default_value, lo + (hi - lo) / 2};
}

// The gateway's answer to a telegram, through its DP service (docs/dp-slave.md "User parameters").
std::optional<dp::PrmFault> gateway_prm_fault(const std::vector<std::uint8_t>& t) {
  struct Discard final : can::FrameSink {
    void send(const can::Frame&) override {}
  } discard;
  gw::Gateway g({}, discard, Time{0});
  if (g.dp().set_prm(1, t, Time{0})) return std::nullopt;
  return g.dp().prm_fault();
}

TEST(PrmMapping, CoversEveryExtUserPrmDataOfTheShippedGsdOnce) {
  ASSERT_EQ(shipped().ext_user_prm_data.size(), 13u);
  std::set<std::string> gsd_names;
  for (const auto& d : shipped().ext_user_prm_data) gsd_names.insert(d.name);
  std::set<std::string> mapped;
  for (const auto& m : param_mappings()) {
    EXPECT_TRUE(mapped.insert(std::string(m.gsd_name)).second) << m.gsd_name << " mapped twice";
    EXPECT_TRUE(gsd_names.count(std::string(m.gsd_name))) << m.gsd_name << " not in the GSD";
  }
  EXPECT_EQ(mapped, gsd_names);
}

TEST(PrmRoundTrip, EveryValueOfEveryParameterDecodesBack) {
  const gw::UserPrm defaults;
  std::size_t checked = 0;
  for (const auto& d : shipped().ext_user_prm_data) {
    const ParamMapping& m = mapping(d.name);
    for (const std::int64_t v : values_of(d)) {
      SCOPED_TRACE(d.name + " = " + std::to_string(v));
      const gsd::PrmOverride ov{d.name, v};
      const gsd::EncodeResult enc = gsd::encode_user_prm(shipped(), {&ov, 1});
      ASSERT_TRUE(enc.ok()) << enc.errors.front();
      ASSERT_EQ(enc.bytes.size(), gw::kUserPrmLen);
      const auto decoded = gw::decode_user_prm(telegram(enc.bytes));
      ASSERT_TRUE(std::holds_alternative<gw::UserPrm>(decoded))
          << "fault at byte " << int(std::get<dp::PrmFault>(decoded).byte);
      const gw::UserPrm& u = std::get<gw::UserPrm>(decoded);
      EXPECT_EQ(m.gsd_value(u), v);
      // Every other parameter keeps its default.
      for (const auto& other : param_mappings()) {
        if (other.gsd_name != m.gsd_name) {
          EXPECT_EQ(other.gsd_value(u), other.gsd_value(defaults)) << other.gsd_name;
        }
      }
      // And the gateway core encodes the decoded parameters to the very same bytes.
      const auto back = gw::encode_user_prm(u);
      EXPECT_EQ(hex_bytes(back), hex_bytes(enc.bytes));
      ++checked;
    }
  }
  EXPECT_GE(checked, 40u);
}

// manual table 5.1.2 / docs/dp-slave.md "User parameters": never CANopen-Slave and -Master
// together; Page-Mode only without either. All 64 combinations of the six flag parameters of byte
// 9.
TEST(PrmRoundTrip, FlagCombinationsOfManualTable512) {
  const char* const flags[] = {"Communication Window", "RTR-Frames",  "CANopen-Slave",
                               "CANopen-Master",       "Start-Frame", "Page-Mode"};
  int rejected = 0;
  for (unsigned bits = 0; bits < 64; ++bits) {
    std::vector<gsd::PrmOverride> ov;
    for (unsigned i = 0; i < 6; ++i) ov.push_back({flags[i], std::int64_t((bits >> i) & 1)});
    const gsd::EncodeResult enc = gsd::encode_user_prm(shipped(), ov);
    ASSERT_TRUE(enc.ok());
    const auto t = telegram(enc.bytes);
    const bool slave = bits & 4, master = bits & 8, page = bits & 32;
    const bool valid = !(slave && master) && !(page && (slave || master));
    const auto decoded = gw::decode_user_prm(t);
    SCOPED_TRACE("flags byte " + hex_bytes(std::span(t).subspan(gw::kPrmFlags, 1)));
    if (valid) {
      ASSERT_TRUE(std::holds_alternative<gw::UserPrm>(decoded));
      for (unsigned i = 0; i < 6; ++i)
        EXPECT_EQ(mapping(flags[i]).gsd_value(std::get<gw::UserPrm>(decoded)), (bits >> i) & 1)
            << flags[i];
      EXPECT_FALSE(gateway_prm_fault(t).has_value());
      continue;
    }
    ++rejected;
    ASSERT_TRUE(std::holds_alternative<dp::PrmFault>(decoded));
    const dp::PrmFault f = std::get<dp::PrmFault>(decoded);
    // The fault the gateway reports on its DP face is the decoder's.
    EXPECT_EQ(gateway_prm_fault(t), f);
    // docs/dp-slave.md "User parameters": byte 9, the flags with the offending bit(s) cleared.
    const std::uint8_t byte = t[gw::kPrmFlags];
    const std::uint8_t offending =
        (slave && master) ? (gw::kFlagCanopenSlave | gw::kFlagCanopenMaster) : gw::kFlagPageMode;
    EXPECT_EQ(f.byte, gw::kPrmFlags);
    EXPECT_EQ(f.correct, byte & ~offending);
  }
  EXPECT_EQ(rejected, 32);  // slave+master: 2^4; Page-Mode with exactly one role: 2 x 2^3
}

gw::UserPrm random_prm(std::mt19937& rng) {
  auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  gw::UserPrm p;
  p.bitrate_index = static_cast<std::uint8_t>(pick(0, gw::kBitrateMax));
  p.comm_window = pick(0, 1);
  p.send_rtr = pick(0, 1);
  p.canopen_slave = pick(0, 1);
  p.canopen_master = pick(0, 1);  // also the combinations the gateway rejects
  p.start_frame = pick(0, 1);
  p.page_mode = pick(0, 1);
  p.module_id = static_cast<std::uint8_t>(pick(1, 127));
  p.can_diagnosis = pick(0, 1);
  p.rx_counter = pick(0, 1);
  p.tx_counter = pick(0, 1);
  p.wakeup_s = static_cast<std::uint8_t>(pick(0, 255));
  p.sync_ms = static_cast<std::uint16_t>(pick(0, 65535));
  return p;
}

// `candp2 validate --gsd gsd/CDPS04A4.GSD` and `candp2 validate` send the same Set_Prm.
TEST(PrmRoundTrip, GsdEncodingEqualsTheBuiltInEncoding) {
  std::mt19937 rng(20240607);  // fixed seed: reproducible
  std::vector<std::pair<gw::UserPrm, std::uint16_t>> cases = {{{}, 0}, {{}, 200}, {{}, 65000}};
  for (int i = 0; i < 500; ++i)
    cases.push_back(
        {random_prm(rng), static_cast<std::uint16_t>(rng() % 3 == 0 ? 0 : rng() % 65001)});
  for (const auto& [p, watchdog] : cases) {
    config::GatewayConfig g;
    g.parameters = p;
    g.watchdog_ms = watchdog;
    const auto builtin = config::set_prm_bytes(g);
    const GsdSetPrm via_gsd = encode_set_prm(shipped(), p, watchdog);
    ASSERT_TRUE(via_gsd.errors.empty()) << via_gsd.errors.front();
    ASSERT_EQ(hex_bytes(via_gsd.telegram), hex_bytes(builtin));
  }
}

// The GSD printed in manual §4 has no Tx-Counter (docs/dp-slave.md "User parameters"): the default
// needs no entry, the counter switched on cannot be encoded through it.
TEST(PrmRoundTrip, AParameterTheGsdLacks) {
  const gsd::ParseResult printed =
      gsd::parse_file(CANDP2_SOURCE_DIR "/tests/validate/configs/printed-manual.gsd");
  ASSERT_TRUE(printed.ok());
  gw::UserPrm p;
  GsdSetPrm r = encode_set_prm(printed.model, p, 0);
  EXPECT_TRUE(r.errors.empty());
  EXPECT_EQ(hex_bytes(r.telegram), hex_bytes(gw::make_set_prm(p)));
  p.tx_counter = true;
  r = encode_set_prm(printed.model, p, 0);
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NE(r.errors[0].find(
                "tx_counter (GSD value 1) needs the ExtUserPrmData \"Tx-Counter\", which the GSD"),
            std::string::npos)
      << r.errors[0];
}

// A GSD of another device: its Ident_Number goes into bytes 4-5, as a configuration tool does.
TEST(PrmRoundTrip, TheIdentNumberComesFromTheGsd) {
  const gsd::ParseResult other =
      gsd::parse_file(CANDP2_SOURCE_DIR "/tests/validate/configs/other-ident.gsd");
  ASSERT_TRUE(other.ok());
  const GsdSetPrm r = encode_set_prm(other.model, {}, 0);
  ASSERT_TRUE(r.errors.empty());
  EXPECT_EQ(hex_bytes(std::span(r.telegram).subspan(4, 2)), "04 A5");
  // docs/dp-slave.md "User parameters": the gateway names byte 5 with the correct value 0xA4.
  EXPECT_EQ(gateway_prm_fault(r.telegram), (dp::PrmFault{5, 0xA4}));
}

// docs/profibus.md "The line in time": the plant's CAN-DP/2 answers no later than the shipped
// GSD's MaxTsdr at each of the ten rates, and it runs at every rate the GSD supports.
TEST(LineLimits, TheBuiltInTableIsTheShippedGsd) {
  for (const std::uint32_t baud : fdl::kLineRates) {
    EXPECT_EQ(gw::max_tsdr_bits(baud), gsd::max_tsdr(shipped(), baud)) << baud;
    EXPECT_TRUE(gsd::supports_rate(shipped(), baud)) << baud;
  }
  EXPECT_EQ(gw::kLineRateLimits.size(), fdl::kLineRates.size());
}

}  // namespace
}  // namespace candp2::validate

// The PLC-side page driver (FB2 equivalent, manual §6.5, §8.2) against the emulated gateway,
// through the simulated DP master's process image.
#include "plc/page_driver.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <set>

#include "fixture.hpp"
#include "gateway/gateway.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::plc {
namespace {

using gw::page::IdEntry;
using gw::test::F;
using gw::test::hex;
using gw::test::Recorder;
using gw::test::V;

IdEntry id11(std::uint32_t id, std::uint8_t form, std::uint8_t len) {
  return {{id, false}, form, len};
}

// Manual §8.2, DB94 / DB95: motors 1, 3, 4, 7, 8.
const std::vector<IdEntry> kMotorTx = {id11(0x201, 0xB8, 6), id11(0x303, 0xB8, 6),
                                       id11(0x304, 0xB8, 6), id11(0x307, 0xB8, 6),
                                       id11(0x308, 0xB8, 6)};
const std::vector<IdEntry> kMotorRx = {id11(0x281, 0xB8, 6), id11(0x283, 0xB8, 6),
                                       id11(0x284, 0xB8, 6), id11(0x287, 0xB8, 6),
                                       id11(0x288, 0xB8, 6)};

// ------------------------------------------------------------------ data blocks

TEST(DataBlocks, ConfigChainAsManualTable652) {
  // manual §6.5.1 example: 16 Tx identifiers in DB11 (10 + DD) and DB12 (6 + EE).
  std::vector<IdEntry> ids;
  for (std::uint32_t i = 0; i < 16; ++i) ids.push_back(id11(0x100 + i, 0, 8));
  const auto chain = make_config_chain(ids, 10);
  ASSERT_EQ(chain.size(), 2u);
  EXPECT_EQ(chain[0].size(), 64u);  // (10 * 6 + 4)
  EXPECT_EQ(chain[1].size(), 40u);  // (6 * 6 + 4)
  EXPECT_EQ(hex(std::span(chain[0]).last(4)), "DD DD DD DD");
  EXPECT_EQ(hex(std::span(chain[1]).last(4)), "EE EE EE EE");
  std::string why;
  const auto raw = parse_config_chain(chain, &why);
  ASSERT_TRUE(raw) << why;
  ASSERT_EQ(raw->size(), 16u);
  EXPECT_EQ(hex((*raw)[15]), "00 00 01 0F 00 08");
  // The DB94 of manual §8.2: CAN_ID1 = DW#16#201, FORMAT1 = B8, LENGTH1 = 6, ..., EEEEEEEE.
  const auto db94 = make_config_chain(kMotorTx);
  EXPECT_EQ(hex(std::span(db94[0]).first(12)), "00 00 02 01 B8 06 00 00 03 03 B8 06");
  EXPECT_EQ(hex(std::span(db94[0]).subspan(30)), "EE EE EE EE");
}

TEST(DataBlocks, ConfigChainErrors) {
  std::string why;
  EXPECT_FALSE(parse_config_chain({{0x00, 0x00, 0x02, 0x01, 0xB8, 0x06}}, &why));
  EXPECT_NE(why.find("without DD DD DD DD or EE EE EE EE"), std::string::npos) << why;
  EXPECT_FALSE(parse_config_chain({{0xDD, 0xDD, 0xDD, 0xDD}}, &why));
  EXPECT_NE(why.find("no DB follows"), std::string::npos) << why;
  EXPECT_FALSE(parse_config_chain({{0x00, 0x00, 0x02, 0x01, 0xB8}}, &why));
  EXPECT_FALSE(parse_config_chain({}, &why));
  EXPECT_TRUE(parse_config_chain({{0xDD, 0xDD, 0xDD, 0xDD}, {0xEE, 0xEE, 0xEE, 0xEE}}, &why));
}

TEST(DataBlocks, WriteDbOfManual82) {
  // manual §8.2 DB96: laenge 7, force, 6 data bytes per motor; laenge6 = EE at byte 40.
  auto db96 = make_data_chain(kMotorTx);
  ASSERT_EQ(db96.size(), 1u);
  EXPECT_EQ(db96[0].size(), 41u);
  EXPECT_EQ(db96[0][40], 0xEE);
  std::string why;
  const auto pos = locate_data_entries(db96, kMotorTx, &why);
  ASSERT_TRUE(pos) << why;
  EXPECT_EQ(*pos, (std::vector<DbPos>{{0, 0}, {0, 8}, {0, 16}, {0, 24}, {0, 32}}));
  EXPECT_EQ(db96[0][8], 7);  // länge = 6 + 1 (manual table 6.5.4)
  // Split over two DBs chained by DD.
  const auto split = make_data_chain(kMotorTx, 3);
  ASSERT_EQ(split.size(), 2u);
  EXPECT_EQ(split[0].back(), 0xDD);
  EXPECT_EQ(*locate_data_entries(split, kMotorTx, &why),
            (std::vector<DbPos>{{0, 0}, {0, 8}, {0, 16}, {1, 0}, {1, 8}}));
  // A länge that does not match the configuration, a missing EE.
  db96[0][8] = 9;
  EXPECT_FALSE(locate_data_entries(db96, kMotorTx, &why));
  EXPECT_NE(why.find("identifier 2"), std::string::npos) << why;
  db96[0][8] = 7;
  db96[0][40] = 0x00;
  EXPECT_FALSE(locate_data_entries(db96, kMotorTx, &why));
  EXPECT_NE(why.find("no EE"), std::string::npos) << why;
}

// ------------------------------------------------------------------ driver + master + gateway

gw::UserPrm page_prm(bool cw) {
  gw::UserPrm p;
  p.page_mode = true;
  p.comm_window = cw;
  return p;
}

// A PLC with a page driver, the DP master and one emulated gateway in Page-Mode with output and
// input segments from PLC address 128 (manual §8.2 DB93), the CW at 240 if wanted.
class DriverFixture : public ::testing::Test {
 protected:
  DriverFixture() { rec.now = &now; }

  void build(const std::vector<std::size_t>& outs, const std::vector<std::size_t>& ins, bool cw,
             PageDriverOptions o = {}) {
    gw::GatewayOptions go;
    go.address = 3;
    go.log = &log;
    gateway = std::make_unique<gw::Gateway>(go, rec, now);
    std::vector<dp::CfgEntry> entries;
    dp::SlaveParameters p;
    std::uint16_t q = 128, i = 128;
    std::size_t out_len = 0;
    for (auto n : outs) {
      entries.push_back(dp::special_output(static_cast<std::uint8_t>(n), true, {}));
      p.addresses.push_back({std::nullopt, q});
      q = static_cast<std::uint16_t>(q + n);
      out_len += n;
    }
    for (auto n : ins) {
      entries.push_back(dp::special_input(static_cast<std::uint8_t>(n), true, {}));
      p.addresses.push_back({i, std::nullopt});
      i = static_cast<std::uint16_t>(i + n);
    }
    if (cw) {
      entries.push_back(dp::special_output(16, true, {0xFF, 0xEF, 0x00}));
      p.addresses.push_back({std::nullopt, 240});
      entries.push_back(dp::special_input(16, true, {0xFF, 0xEF, 0x00}));
      p.addresses.push_back({240, std::nullopt});
    }
    const auto prm = gw::make_set_prm(page_prm(cw));
    p.prm = {prm.begin(), prm.end()};
    p.cfg = dp::encode_chk_cfg(entries);
    master = std::make_unique<dp::DpMaster>(dp::MasterOptions{1, milliseconds(1000)}, &log);
    master->add_slave(gateway->dp(), p);
    o.write_address = 128;
    o.read_address = 128;
    o.output_page_len = out_len;
    driver = std::make_unique<PageDriver>(o, &log);
    master->set_program(driver.get());
  }
  void configure(const std::vector<IdEntry>& tx, const std::vector<IdEntry>& rx,
                 std::size_t per_db = 0) {
    driver->write_config_db() = make_config_chain(tx, per_db);
    driver->read_config_db() = make_config_chain(rx, per_db);
    driver->write_db() = make_data_chain(tx, per_db);
    driver->read_db() = make_data_chain(rx, per_db);
    tx_ids = tx;
    rx_ids = rx;
  }
  void cycle(int n = 1) {
    for (int k = 0; k < n; ++k) {
      master->cycle(now);
      now += milliseconds(10);
    }
  }
  // Cycles until the driver's RET_VALUE is `v` (bounded).
  bool cycle_until(RetValue v, int max = 1000) {
    for (int k = 0; k < max; ++k) {
      if (driver->ret_value() == v) return true;
      cycle();
    }
    return driver->ret_value() == v;
  }
  void set_tx(std::size_t i, std::uint8_t force, std::vector<std::uint8_t> data) {
    const auto pos = *locate_data_entries(driver->write_db(), tx_ids, nullptr);
    auto& db = driver->write_db()[pos[i].db];
    db[pos[i].offset + 1] = force;
    std::copy(data.begin(), data.end(),
              db.begin() + static_cast<std::ptrdiff_t>(pos[i].offset + 2));
  }
  std::string read_rx(std::size_t i) {
    const auto pos = *locate_data_entries(driver->read_db(), rx_ids, nullptr);
    const auto& db = driver->read_db()[pos[i].db];
    return hex(std::span(db).subspan(pos[i].offset, 2u + rx_ids[i].length));
  }
  // Runs until the driver completed `n` more rotations; returns the frames sent meanwhile (from a
  // rotation boundary on when called at one, as after cycle_until(RetValue::Data)).
  std::vector<std::string> rotations(std::uint64_t n) {
    const auto target = driver->rotations() + n;
    for (int k = 0; k < 10000 && driver->rotations() < target; ++k) cycle();
    return rec.take();
  }

  Time now{0};
  Recorder rec;
  MemoryLog log;
  std::unique_ptr<gw::Gateway> gateway;
  std::unique_ptr<dp::DpMaster> master;
  std::unique_ptr<PageDriver> driver;
  std::vector<IdEntry> tx_ids, rx_ids;
};

TEST_F(DriverFixture, RetValueFollowsThePageTypes) {
  build({32, 32, 32, 9}, {32, 32, 32, 9}, true);
  configure(kMotorTx, kMotorRx);
  // FREIGABE = 0: page 0/1 only (manual §6.5.1), RET_VALUE 0.
  cycle(10);
  EXPECT_EQ(driver->state(), PageDriver::State::Ready);
  EXPECT_EQ(driver->ret_value(), RetValue::None);
  EXPECT_EQ(hex(std::span(master->image().inputs).subspan(128, 11)).substr(0, 5), "00 01");
  driver->set_freigabe(true);
  std::vector<RetValue> seen = {driver->ret_value()};
  for (int k = 0; k < 20; ++k) {
    cycle();
    if (driver->ret_value() != seen.back()) seen.push_back(driver->ret_value());
  }
  // manual table 6.5.7: 2 Tx configuration, 3 Rx configuration, 4 data pages.
  EXPECT_EQ(seen, (std::vector<RetValue>{RetValue::None, RetValue::TxConfig, RetValue::RxConfig,
                                         RetValue::Data}));
  EXPECT_EQ(driver->data_pages(), 1u);
  EXPECT_EQ(gateway->status().tx_frames, 0u);  // DB96 as created: force 0 everywhere
}

TEST_F(DriverFixture, Manual82FramesFollowTable647) {
  build({32, 32, 32, 9}, {32, 32, 32, 9}, true);
  configure(kMotorTx, kMotorRx);
  // DB96 of manual §8.2: force 2, 1, 4, 0, 3.
  const std::vector<std::uint8_t> zero(6, 0);
  for (std::size_t i = 0; i < 5; ++i)
    set_tx(i, std::array<std::uint8_t, 5>{2, 1, 4, 0, 3}[i], zero);
  driver->set_freigabe(true);
  ASSERT_TRUE(cycle_until(RetValue::Data));
  EXPECT_EQ(rotations(1),
            V({"201#000000000000", "303#000000000000", "304#000000000000", "308#000000000000"}));
  EXPECT_EQ(rotations(3), V({"303#000000000000", "303#000000000000", "303#000000000000"}));
  set_tx(0, 2, {1, 2, 3, 4, 5, 6});  // new data, force 2: once
  EXPECT_EQ(rotations(2), V({"201#020106050403", "303#000000000000", "303#000000000000"}));
  set_tx(4, 4, zero);  // 3 -> 4: once more
  EXPECT_EQ(rotations(2), V({"303#000000000000", "308#000000000000", "303#000000000000"}));
  set_tx(4, 3, zero);  // 4 -> 3: again
  EXPECT_EQ(rotations(1), V({"303#000000000000", "308#000000000000"}));
  set_tx(3, 0, {9, 9, 9, 9, 9, 9});  // motor 7 stays silent
  EXPECT_EQ(rotations(1), V({"303#000000000000"}));
  // Rx: count_in and data land in DB97 as manual table 6.5.6 lays them out.
  gateway->on_can_frame(F("284#020106050403"), now);
  rotations(1);
  EXPECT_EQ(read_rx(2), "07 01 01 02 03 04 05 06");
}

TEST_F(DriverFixture, HundredTwentySevenMotorsEveryFrameBothWaysTwoCyclesPerPage) {
  // 127 Tx + 127 Rx identifiers of 6 bytes through 32-byte segments (manual §6.4.1, 105-byte
  // pages of §6.4.2 example 1), the DBs split into DBs of 10 identifiers chained by DD.
  build({32, 32, 32, 9}, {32, 32, 32, 9}, true);
  std::vector<IdEntry> tx, rx;
  for (std::uint32_t m = 1; m <= 127; ++m) {
    tx.push_back(id11(0x200 + m, 0x00, 6));
    rx.push_back(id11(0x280 + m, 0x00, 6));
  }
  configure(tx, rx, 10);
  for (std::size_t i = 0; i < tx.size(); ++i)
    set_tx(i, 1, {0xA0, static_cast<std::uint8_t>(i + 1), 0, 0, 0, 0x0A});
  driver->set_freigabe(true);
  ASSERT_TRUE(cycle_until(RetValue::Data));
  // 12 entries of 7 bytes per 105-byte page (regions 24, 30, 30, 7): 11 data pages.
  EXPECT_EQ(driver->data_pages(), 11u);
  rotations(1);  // a first full rotation
  for (std::uint32_t m = 1; m <= 127; ++m) {
    char f[32];
    std::snprintf(f, sizeof f, "%03X#B0%02X0000000B", 0x280 + m, m);
    gateway->on_can_frame(F(f), now);
  }
  const auto scans = driver->scans();
  const auto frames = rotations(1);
  // manual §6.1: two PLC cycles per page; a rotation over N pages takes 2 N cycles.
  EXPECT_EQ(driver->scans() - scans, 2u * 11u);
  const std::set<std::string> distinct(frames.begin(), frames.end());
  EXPECT_EQ(frames.size(), 127u);
  EXPECT_EQ(distinct.size(), 127u);
  EXPECT_EQ(distinct.count("201#A0010000000A"), 1u);
  EXPECT_EQ(distinct.count("27F#A07F0000000A"), 1u);
  for (std::size_t i = 0; i < rx.size(); ++i) {
    char want[64];
    std::snprintf(want, sizeof want, "07 01 B0 %02X 00 00 00 0B", static_cast<unsigned>(i + 1));
    EXPECT_EQ(read_rx(i), want) << "Rx " << i + 1;
  }
}

TEST_F(DriverFixture, BadEntryStatusTwoIsAnErrorAndRetried) {
  PageDriverOptions o;
  o.retry_delay = milliseconds(200);
  build({32}, {32}, false, o);
  configure({id11(0x100, 0, 1)}, {});
  driver->write_config_db()[0][5] = 9;  // länge 9 (manual §6.4.5: 1..8)
  driver->set_freigabe(true);
  cycle(8);
  EXPECT_EQ(driver->state(), PageDriver::State::Error);
  EXPECT_NE(driver->last_error().find("status 2"), std::string::npos) << driver->last_error();
  EXPECT_TRUE(log.contains("bad entry"));
  const auto restarts = driver->restarts();
  driver->write_config_db()[0][5] = 1;  // fixed meanwhile
  ASSERT_TRUE(cycle_until(RetValue::Data, 100));
  EXPECT_EQ(driver->restarts(), restarts + 1);
}

TEST_F(DriverFixture, GatewayPowerCycleStatusFourConfiguresAgain) {
  PageDriverOptions o;
  o.ack_timeout = seconds(5);
  build({32}, {32}, false, o);
  const std::vector<IdEntry> tx = {id11(0x123, 0, 1)};
  configure(tx, {});
  set_tx(0, 1, {0x42});
  driver->set_freigabe(true);
  ASSERT_TRUE(cycle_until(RetValue::Data));
  const auto restarts = driver->restarts();
  gateway->power_cycle(now);  // loses the Page-Mode configuration
  cycle(200);                 // the master parameterizes it again after its retry delay
  EXPECT_TRUE(log.contains("status 4"));
  EXPECT_EQ(driver->restarts(), restarts + 1);
  EXPECT_EQ(driver->ret_value(), RetValue::Data);
  rotations(1);                            // to a rotation boundary
  EXPECT_EQ(rotations(1), V({"123#42"}));  // force 1 on the one data page, sending again
}

TEST(PageDriverAlone, NoAnswerRestartsAfterTheAckTimeout) {
  MemoryLog log;
  PageDriverOptions o;
  o.write_address = 0;
  o.read_address = 0;
  o.output_page_len = 32;
  o.ack_timeout = milliseconds(100);
  PageDriver d(o, &log);
  dp::ProcessImage image;
  Time t{0};
  for (int k = 0; k < 25; ++k, t += milliseconds(10)) d.scan(image, t);
  EXPECT_EQ(d.restarts(), 3u);  // at 0, 100, 200 ms
  EXPECT_TRUE(log.contains("no answer to page 0"));
  EXPECT_EQ(hex(std::span(image.outputs).first(3)), "00 00 03");  // page 0, sequence 3
}

TEST_F(DriverFixture, OutputPageLengthMismatchIsReported) {
  PageDriverOptions o;
  build({32, 16}, {32}, false, o);
  driver = std::make_unique<PageDriver>(
      PageDriverOptions{128, 128, 32, Duration{0}, milliseconds(1000), milliseconds(1000)}, &log);
  master->set_program(driver.get());
  configure({}, {});
  cycle(8);
  EXPECT_EQ(driver->state(), PageDriver::State::Error);
  EXPECT_NE(driver->last_error().find("output page is 48 bytes"), std::string::npos)
      << driver->last_error();
}

TEST_F(DriverFixture, FreigabeZeroStartsAgainWithPage0) {
  build({32}, {32}, false);
  configure({id11(0x123, 0, 1)}, {});
  driver->set_freigabe(true);
  ASSERT_TRUE(cycle_until(RetValue::Data));
  driver->set_freigabe(false);
  cycle(4);
  EXPECT_EQ(driver->state(), PageDriver::State::Ready);
  EXPECT_EQ(gateway->dp().state(), dp::SlaveState::DataExch);
  EXPECT_EQ(hex(std::span(master->image().inputs).subspan(128, 2)), "00 01");  // page 1 answer
}

}  // namespace
}  // namespace candp2::plc

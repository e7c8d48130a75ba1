// Page-Mode, gateway side (manual §6, docs/page-mode.md): layout, pages 0/1, configuration pages,
// data pages with force and count_in, acknowledge, torn pages, status codes.
#include "gateway/page_mode.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <set>

#include "fixture.hpp"

namespace candp2::gw::test {
namespace {

using page::IdEntry;
using page::Layout;
using page::Status;

UserPrm page_prm() {
  UserPrm p;
  p.page_mode = true;
  return p;
}

std::vector<std::uint8_t> segments_cfg(const std::vector<std::size_t>& outs,
                                       const std::vector<std::size_t>& ins, bool cw = false) {
  std::vector<dp::CfgEntry> e;
  for (auto n : outs) e.push_back(out_slot(static_cast<std::uint8_t>(n), {}));
  for (auto n : ins) e.push_back(in_slot(static_cast<std::uint8_t>(n), {}));
  if (cw) {
    e.push_back(out_slot(16, {0xFF, 0xEF, 0x00}));
    e.push_back(in_slot(16, {0xFF, 0xEF, 0x00}));
  }
  return dp::encode_chk_cfg(e);
}

IdEntry id11(std::uint32_t id, std::uint8_t form, std::uint8_t len) {
  return {{id, false}, form, len};
}

// A PLC that writes pages byte by byte through the fixture's Data_Exchange.
class PageModeTest : public GatewayFixture {
 protected:
  void setup(std::vector<std::size_t> outs, std::vector<std::size_t> ins, bool cw = false) {
    GatewayOptions o;
    o.log = &mlog;
    make(o);
    UserPrm p = page_prm();
    p.comm_window = cw;
    ASSERT_TRUE(configure(p, segments_cfg(outs, ins, cw)));
    out = Layout(outs);
    in = Layout(ins);
    extra_out = cw ? 16 : 0;
    in_len = in.size();
  }
  // A blank output page: page number in every segment, the next sequence number, zero payload.
  std::vector<std::uint8_t> blank(std::uint16_t number) {
    std::vector<std::uint8_t> p(out.size() + extra_out, 0);
    page::put_page_number(out, p, number);
    p[page::kSeqByte] = ++seq;
    return p;
  }
  // One Data_Exchange; returns the input page.
  std::vector<std::uint8_t> send(const std::vector<std::uint8_t>& p) {
    auto i = exchange(p);
    i.resize(in_len);
    return i;
  }
  std::vector<std::uint8_t> init() { return send(blank(0)); }
  std::vector<std::uint8_t> config(std::uint16_t number, const std::vector<IdEntry>& entries,
                                   std::size_t* placed = nullptr) {
    auto p = blank(number);
    const auto n = page::encode_config_page(out, entries, p);
    if (placed) *placed = n;
    return send(p);
  }
  // Page 0, then every Tx and Rx configuration page; returns the last answer.
  std::vector<std::uint8_t> configure_all(const std::vector<IdEntry>& tx,
                                          const std::vector<IdEntry>& rx) {
    init();
    std::vector<std::uint8_t> a;
    for (auto [list, first] : {std::pair{&tx, page::kTxConfigFirst}, {&rx, page::kRxConfigFirst}}) {
      std::span<const IdEntry> rest(*list);
      std::uint16_t number = first;
      do {
        std::size_t n = 0;
        a = config(number++, {rest.begin(), rest.end()}, &n);
        EXPECT_EQ(status(a), 0) << "page " << number - 1;
        rest = rest.subspan(n);
      } while (!rest.empty());
    }
    return a;
  }
  // A data page with (force, data) per Tx entry placed on it.
  std::vector<std::uint8_t> data_page(
      std::uint16_t number, const std::vector<IdEntry>& tx,
      const std::map<std::size_t, std::pair<std::uint8_t, std::vector<std::uint8_t>>>& values) {
    auto p = blank(number);
    const auto places = page::pack_data(out, tx);
    for (const auto& [i, v] : values) {
      EXPECT_EQ(places[i].page, number - page::kDataFirst) << "entry " << i;
      p[places[i].offset] = v.first;
      std::copy(v.second.begin(), v.second.end(), p.begin() + places[i].offset + 1);
    }
    return p;
  }

  void rx_frame(const std::string& f) { gw->on_can_frame(F(f.c_str()), now); }
  bool log_has(std::string_view s) const { return mlog.contains(s); }

  static std::uint16_t number(const std::vector<std::uint8_t>& a) { return page::get_be16(a, 0); }
  static int ack(const std::vector<std::uint8_t>& a) { return a[page::kSeqByte]; }
  static int status(const std::vector<std::uint8_t>& a) { return a[page::kStatusByte]; }
  static int w4(const std::vector<std::uint8_t>& a) { return page::get_be16(a, page::kWord4); }
  static int w6(const std::vector<std::uint8_t>& a) { return page::get_be16(a, page::kWord6); }
  static std::string bytes(const std::vector<std::uint8_t>& a, std::size_t from, std::size_t n) {
    return hex(std::span(a).subspan(from, n));
  }

  MemoryLog mlog;
  Layout out, in;
  std::size_t extra_out = 0, in_len = 0;
  std::uint8_t seq = 0;
};

// The 5 motors of manual §8.2 (DB94/DB95): form B8, 6 data bytes.
const std::vector<IdEntry> kMotorTx = {id11(0x201, 0xB8, 6), id11(0x303, 0xB8, 6),
                                       id11(0x304, 0xB8, 6), id11(0x307, 0xB8, 6),
                                       id11(0x308, 0xB8, 6)};
const std::vector<IdEntry> kMotorRx = {id11(0x281, 0xB8, 6), id11(0x283, 0xB8, 6),
                                       id11(0x284, 0xB8, 6), id11(0x287, 0xB8, 6),
                                       id11(0x288, 0xB8, 6)};

std::vector<IdEntry> many(std::uint32_t first, std::size_t n, std::uint8_t len) {
  std::vector<IdEntry> v;
  for (std::size_t i = 0; i < n; ++i)
    v.push_back(id11(first + static_cast<std::uint32_t>(i), 0, len));
  return v;
}

// ------------------------------------------------------------------ wire format

TEST(PageLayout, RegionsFollowSpec61) {
  // Manual §6.4.2 example 2: 32 + 32 + 18 bytes; first segment payload from byte 8, further
  // segments from byte 2 (docs/page-mode.md "Segments").
  const Layout l({32, 32, 18});
  EXPECT_EQ(l.size(), 82u);
  EXPECT_EQ(l.regions(), (std::vector<page::Region>{{8, 24}, {34, 30}, {66, 16}}));
  EXPECT_EQ(l.max_entry(), 30u);
  EXPECT_EQ(l.segment_offsets(), (std::vector<std::size_t>{0, 32, 64}));
  ASSERT_TRUE(Layout::from_sizes(82, 3));
  EXPECT_EQ(Layout::from_sizes(82, 3)->segments(), (std::vector<std::size_t>{32, 32, 18}));
  EXPECT_FALSE(Layout::from_sizes(82, 2));  // 82 - 32 = 50 > 32
  EXPECT_FALSE(Layout::from_sizes(64, 3));  // the last segment would be empty
}

TEST(PageLayout, Manual642Example2ElevenTxIdentifiersOnPage51) {
  // manual §6.4.2 example 2: an 82-byte output page holds 11 Tx identifiers on page 51, the end
  // marker in its last four bytes.
  const Layout l({32, 32, 18});
  const auto ids = many(0x100, 12, 8);
  std::vector<std::uint8_t> p(82, 0);
  EXPECT_EQ(page::encode_config_page(l, std::span(ids).first(11), p), 11u);
  const std::vector<std::size_t> at = {8, 14, 20, 26, 34, 40, 46, 52, 58, 66, 72};
  for (std::size_t i = 0; i < at.size(); ++i)
    EXPECT_EQ(hex(std::span(p).subspan(at[i], 6)),
              "00 00 01 " + hex(std::vector<std::uint8_t>{static_cast<std::uint8_t>(i)}) + " 00 08")
        << "entry " << i + 1;
  EXPECT_EQ(hex(std::span(p).subspan(78, 4)), "EE EE EE EE");
  // A twelfth identifier does not fit: 11 go on the page, DD says more pages follow.
  EXPECT_EQ(page::encode_config_page(l, ids, p), 11u);
  EXPECT_EQ(hex(std::span(p).subspan(78, 4)), "DD DD DD DD");
  page::ConfigPageFault f;
  auto d = page::decode_config_page(l, p, &f);
  ASSERT_TRUE(d) << f.why;
  EXPECT_EQ(d->entries.size(), 11u);
  EXPECT_FALSE(d->complete);
}

TEST(PageLayout, EntryEncodingAndValidation) {
  // docs/page-mode.md "Pages": identifier big-endian, bit 29 flags 29-bit; manual DB94: 0x201, B8,
  // 6.
  EXPECT_EQ(hex(page::encode_entry(id11(0x201, 0xB8, 6))), "00 00 02 01 B8 06");
  EXPECT_EQ(hex(page::encode_entry({{0x123456, true}, 0x00, 8})), "20 12 34 56 00 08");
  std::string why;
  auto e = page::decode_entry(std::vector<std::uint8_t>{0x3F, 0xFF, 0xFF, 0xFF, 0, 1}, &why);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->id, (can::Ident{0x1FFFFFFF, true}));
  EXPECT_FALSE(page::decode_entry(std::vector<std::uint8_t>{0, 0, 0x08, 0x00, 0, 1}, &why));
  EXPECT_NE(why.find("7FF"), std::string::npos) << why;
  EXPECT_FALSE(page::decode_entry(std::vector<std::uint8_t>{0, 0, 1, 0, 0, 0}, &why));
  EXPECT_NE(why.find("length 0"), std::string::npos) << why;
  EXPECT_FALSE(page::decode_entry(std::vector<std::uint8_t>{0, 0, 1, 0, 0, 9}, &why));
  EXPECT_FALSE(page::decode_entry(std::vector<std::uint8_t>{0x40, 0, 1, 0, 0, 1}, &why));
}

TEST(PageLayout, DataEntriesNeverStraddleSegments) {
  // 105-byte page of manual §6.4.2 example 1 (32+32+32+9): regions 24, 30, 30, 7. Entries of
  // force + 6 bytes: 3 + 4 + 4 + 1 = 12 per page.
  const Layout l({32, 32, 32, 9});
  const auto places = page::pack_data(l, many(0x200, 13, 6));
  ASSERT_EQ(places.size(), 13u);
  EXPECT_EQ(places[0], (page::DataPlace{0, 8}));
  EXPECT_EQ(places[2], (page::DataPlace{0, 22}));
  EXPECT_EQ(places[3], (page::DataPlace{0, 34}));  // 29..31 unused
  EXPECT_EQ(places[7], (page::DataPlace{0, 66}));
  EXPECT_EQ(places[11], (page::DataPlace{0, 98}));
  EXPECT_EQ(places[12], (page::DataPlace{1, 8}));
  EXPECT_EQ(page::pages_used(places), 2u);
}

// ------------------------------------------------------------------ pages 0 and 1

TEST_F(PageModeTest, Page0AnswersPage1WithSizes) {
  setup({32, 32, 18}, {32, 32}, true);
  const auto a = init();
  // docs/page-mode.md "Pages": page 1, ack, status 0, output 82 / input 64 bytes, 3 / 2 segments,
  // CW.
  EXPECT_EQ(bytes(a, 0, 11), "00 01 01 00 00 52 00 40 03 02 01");
  EXPECT_EQ(bytes(a, 32, 2), "00 01");  // every input segment starts with the page number
  EXPECT_EQ(gw->status().tx_frames, 0u);
}

TEST_F(PageModeTest, InitialZeroImageIsPage0AndSequenceZero) {
  setup({32}, {32});
  // The all-zero output image before the PLC writes is page 0 with sequence 0: a harmless reset.
  auto a = send(std::vector<std::uint8_t>(32, 0));
  EXPECT_EQ(bytes(a, 0, 4), "00 01 00 00");
  EXPECT_EQ(gw->status().tx_frames, 0u);
}

TEST_F(PageModeTest, PowerCycleStartsThePageCountAtZero) {
  // docs/faults.md "Power cycle and re-parameterization": a restarted gateway starts every counter
  // at 0, the pages processed (the HTTP status page's count) too.
  setup({32}, {32});
  init();
  config(51, many(0x100, 1, 8));
  ASSERT_GT(gw->page_mode().pages_processed(), 0u);
  gw->power_cycle(now);
  EXPECT_EQ(gw->page_mode().pages_processed(), 0u);
  EXPECT_EQ(gw->page_mode().state(), PageMode::State::WaitInit);
}

// ------------------------------------------------------------------ configuration pages

TEST_F(PageModeTest, Manual642Example2GatewayTakesElevenIdentifiers) {
  setup({32, 32, 18}, {32, 32});
  init();
  const auto ids = many(0x100, 11, 8);
  const auto a = config(51, ids);
  EXPECT_EQ(number(a), 51);
  EXPECT_EQ(ack(a), seq);
  EXPECT_EQ(status(a), 0);
  EXPECT_EQ(w6(a), 11);  // Tx identifiers configured so far
  EXPECT_EQ(gw->slot_config()->page_mode, true);
}

TEST_F(PageModeTest, ConfigurationOverSeveralPagesAndDataPageCount) {
  setup({32, 32, 18}, {32, 32});
  const auto tx = many(0x100, 30, 8);  // 9 bytes per data entry
  const auto rx = many(0x300, 20, 8);
  init();
  std::size_t n = 0;
  auto a = config(51, tx, &n);
  EXPECT_EQ(n, 11u);
  EXPECT_EQ(w6(a), 11);
  a = config(52, std::vector<IdEntry>(tx.begin() + 11, tx.end()), &n);
  EXPECT_EQ(n, 11u);
  a = config(53, std::vector<IdEntry>(tx.begin() + 22, tx.end()), &n);
  EXPECT_EQ(n, 8u);
  EXPECT_EQ(w6(a), 30);
  a = config(151, rx, &n);
  EXPECT_EQ(n, 11u);
  a = config(152, std::vector<IdEntry>(rx.begin() + 11, rx.end()), &n);
  EXPECT_EQ(status(a), 0);
  EXPECT_EQ(w6(a), 20);
  // Output: regions 24/30/16 hold 2+3+1 = 6 entries of 9 bytes → 5 pages for 30; input: 24/30
  // hold 2+3 = 5 → 4 pages for 20. N = 5 (docs/page-mode.md "Pages").
  const auto d = send(blank(251));
  EXPECT_EQ(status(d), 0);
  EXPECT_EQ(w4(d), 5);  // Rx entries on page 251
  EXPECT_EQ(w6(d), 5);  // N
  EXPECT_EQ(status(send(blank(255))), 0);
  EXPECT_EQ(w4(send(blank(255))), 0);  // Rx entries end on page 254
  EXPECT_EQ(status(send(blank(256))), 1);
}

TEST_F(PageModeTest, ConfigurationPagesOutOfOrder) {
  setup({32, 32, 18}, {32, 32});
  init();
  auto a = config(52, many(0x100, 2, 8));  // 51 expected
  EXPECT_EQ(number(a), 52);
  EXPECT_EQ(status(a), static_cast<int>(Status::Unexpected));
  EXPECT_EQ(ack(a), seq);              // an error answer acknowledges the page too
  a = config(151, many(0x300, 2, 8));  // Rx before Tx is complete
  EXPECT_EQ(status(a), 1);
  a = config(51, many(0x100, 2, 8));
  EXPECT_EQ(status(a), 0);
  a = config(51, many(0x100, 2, 8));  // Tx configuration already complete
  EXPECT_EQ(status(a), 1);
  a = config(151, many(0x300, 2, 8));
  EXPECT_EQ(status(a), 0);
  EXPECT_EQ(status(config(152, {})), 1);  // Rx configuration already complete
  EXPECT_EQ(gw->dp().state(), dp::SlaveState::DataExch);
}

TEST_F(PageModeTest, StatusOnePages1To50AndBeyondN) {
  setup({32}, {32});
  for (std::uint16_t n : {1, 2, 50}) {
    const auto a = send(blank(n));
    EXPECT_EQ(number(a), n);
    EXPECT_EQ(status(a), 1) << n;
  }
  configure_all(many(0x100, 1, 1), {});
  EXPECT_EQ(status(send(blank(251))), 0);
  const auto a = send(blank(252));
  EXPECT_EQ(status(a), 1);
  EXPECT_EQ(w6(a), 1);
}

TEST_F(PageModeTest, StatusTwoBadEntries) {
  setup({32, 32, 18}, {32, 32});
  init();
  // Length 9 (manual §6.4.5: 1..8).
  auto p = blank(51);
  const std::vector<std::uint8_t> bad = {0x00, 0x00, 0x01, 0x00, 0x00,
                                         0x09, 0xEE, 0xEE, 0xEE, 0xEE};
  std::copy(bad.begin(), bad.end(), p.begin() + 8);
  auto a = send(p);
  EXPECT_EQ(status(a), static_cast<int>(Status::BadEntry));
  EXPECT_EQ(w6(a), 0);
  // 11-bit identifier above 7FF.
  p = blank(51);
  const std::vector<std::uint8_t> big = {0x00, 0x00, 0x08, 0x00, 0x00,
                                         0x01, 0xEE, 0xEE, 0xEE, 0xEE};
  std::copy(big.begin(), big.end(), p.begin() + 8);
  EXPECT_EQ(status(send(p)), 2);
  // Every region filled with entries, no room left for an end marker.
  p = blank(51);
  page::Packer packer(out);
  for (std::uint32_t id = 0x100; auto at = packer.place(page::kEntryLen); ++id) {
    const auto e = page::encode_entry(id11(id, 0, 1));
    std::copy(e.begin(), e.end(), p.begin() + static_cast<std::ptrdiff_t>(*at));
  }
  EXPECT_EQ(status(send(p)), 2);
  EXPECT_TRUE(log_has("no end marker"));
  // The page was refused as a whole: 51 is still expected and nothing was taken.
  a = config(51, many(0x100, 2, 8));
  EXPECT_EQ(status(a), 0);
  EXPECT_EQ(w6(a), 2);
  // manual §2.2: an Rx identifier already used for Tx.
  a = config(151, {id11(0x300, 0, 8), id11(0x101, 0, 8)});
  EXPECT_EQ(status(a), 2);
  EXPECT_EQ(w6(a), 0);
}

TEST_F(PageModeTest, SmallOutputPagesCarryOneEntryPerConfigurationPage) {
  // A single 12-byte output segment has 4 payload bytes: room for an end marker, not an entry.
  setup({12}, {32});
  init();
  std::size_t placed = 9;
  auto a = config(51, {id11(0x100, 0, 8)}, &placed);
  EXPECT_EQ(placed, 0u);  // the PLC side cannot place it: DD, nothing configured
  EXPECT_EQ(status(a), 0);
  EXPECT_EQ(w6(a), 0);
  // An 18-byte output segment: 10 payload bytes, one entry and the marker per configuration page.
  setup({18}, {32});
  init();
  config(51, {});  // EE only: no Tx identifiers
  a = config(151, {id11(0x181, 0, 8), id11(0x182, 0, 1)}, &placed);
  EXPECT_EQ(placed, 1u);
  a = config(152, {id11(0x182, 0, 1)}, &placed);
  EXPECT_EQ(placed, 1u);
  EXPECT_EQ(status(a), 0);
  EXPECT_EQ(w6(a), 2);
  rx_frame("181#0102030405060708");
  a = send(blank(251));
  EXPECT_EQ(status(a), 0);
  EXPECT_EQ(bytes(a, 8, 11), "01 01 02 03 04 05 06 07 08 00 00");
}

TEST_F(PageModeTest, StatusThreeTooManyIdentifiers) {
  // 244-byte output page: 7 x 32 + 20 (regions 24 + 6 x 30 + 18) = 4 + 30 + 2 entries and a
  // marker per page; page 107 would pass 2048 (this product's limit, page::kMaxIdentifiers).
  setup({32, 32, 32, 32, 32, 32, 32, 20}, {32});
  init();
  std::vector<IdEntry> ids;
  for (std::uint32_t i = 0; i < 2100; ++i) ids.push_back({{0x10000 + i, true}, 0, 1});
  std::span<const IdEntry> rest(ids);
  std::uint16_t number = 51;
  std::vector<std::uint8_t> a;
  std::size_t total = 0;
  while (true) {
    std::size_t n = 0;
    a = config(number, {rest.begin(), rest.end()}, &n);
    if (status(a) != 0) break;
    total += n;
    rest = rest.subspan(n);
    ++number;
  }
  EXPECT_EQ(status(a), static_cast<int>(Status::TooMany));
  EXPECT_EQ(number, 51 + 56);
  EXPECT_EQ(total, 56u * 36u);
  EXPECT_EQ(w6(a), 56 * 36);
  EXPECT_LE(total, page::kMaxIdentifiers);
}

TEST_F(PageModeTest, StatusThreeMoreMarkerOnPage150) {
  setup({32}, {32});
  init();
  std::vector<std::uint8_t> a;
  for (std::uint16_t n = 51; n <= 150; ++n) {
    auto p = blank(n);
    std::fill_n(p.begin() + 8, 4, 0xDD);  // no entries, "more pages follow"
    a = send(p);
    if (n < 150) {
      ASSERT_EQ(status(a), 0) << n;
    }
  }
  EXPECT_EQ(status(a), 3);
}

TEST_F(PageModeTest, StatusFourDataPageBeforeConfigurationComplete) {
  setup({32}, {32});
  auto a = send(blank(251));  // before page 0
  EXPECT_EQ(status(a), static_cast<int>(Status::NotConfigured));
  EXPECT_EQ(number(a), 251);
  init();
  config(51, many(0x100, 1, 1));
  a = send(blank(251));  // Rx configuration missing
  EXPECT_EQ(status(a), 4);
  EXPECT_EQ(ack(a), seq);
}

// ------------------------------------------------------------------ acknowledge, torn pages

TEST_F(PageModeTest, RepeatedSequenceNumberIsNotProcessedAgain) {
  setup({32}, {32});
  const std::vector<IdEntry> tx = {id11(0x123, 0, 2)};
  configure_all(tx, {});
  auto p = data_page(251, tx, {{0, {1, {0xAA, 0xBB}}}});  // force 1: every processed page
  send(p);
  EXPECT_EQ(rec.take(), V({"123#AABB"}));
  send(p);  // same sequence number: the gateway already answered it
  send(p);
  EXPECT_TRUE(rec.take().empty());
  const auto processed = gw->status().tx_frames;
  p[page::kSeqByte] = ++seq;
  const auto a = send(p);
  EXPECT_EQ(ack(a), seq);
  EXPECT_EQ(rec.take(), V({"123#AABB"}));
  EXPECT_EQ(gw->status().tx_frames, processed + 1);
}

TEST_F(PageModeTest, TornPageIgnoredUntilConsistent) {
  setup({32, 32, 18}, {32, 32});
  const std::vector<IdEntry> tx = many(0x100, 11, 8);
  init();
  const auto before = send(blank(0));  // a fresh init: ack = seq
  auto p = blank(51);
  page::encode_config_page(out, tx, p);
  p[33] = 0x00;  // segment 1 still carries page 0 (its bytes 32-33 = 00 00)
  p[32] = 0x00;
  auto a = send(p);
  EXPECT_EQ(a, before) << "a torn page gets no answer";
  EXPECT_TRUE(log_has("torn output page"));
  p[33] = 51;  // the PLC finished writing segment 1
  a = send(p);
  EXPECT_EQ(number(a), 51);
  EXPECT_EQ(ack(a), seq);
  EXPECT_EQ(w6(a), 11);
}

TEST_F(PageModeTest, Page0ResetsMidExchange) {
  setup({32}, {32});
  const std::vector<IdEntry> tx = {id11(0x123, 0, 1)};
  const std::vector<IdEntry> rx = {id11(0x181, 0, 1)};
  configure_all(tx, rx);
  rx_frame("181#05");
  auto a = send(data_page(251, tx, {{0, {1, {0x01}}}}));
  EXPECT_EQ(bytes(a, 8, 2), "01 05");
  EXPECT_EQ(rec.take(), V({"123#01"}));
  a = init();
  EXPECT_EQ(number(a), 1);
  EXPECT_EQ(gw->status().tx_frames, 1u);
  rx_frame("181#06");  // not configured any more: ignored
  a = send(data_page(251, tx, {{0, {1, {0x02}}}}));
  EXPECT_EQ(status(a), 4);
  EXPECT_TRUE(rec.take().empty());
  // Configured again: count_in starts from zero, force 3/4 history is gone.
  configure_all(tx, rx);
  rx_frame("181#07");
  a = send(data_page(251, tx, {{0, {3, {0x03}}}}));
  EXPECT_EQ(bytes(a, 8, 2), "01 07");
  EXPECT_EQ(rec.take(), V({"123#03"}));
}

// ------------------------------------------------------------------ data pages

TEST_F(PageModeTest, Manual82ForceTable647) {
  // manual §8.2: motors 1, 3, 4, 7, 8; DB96 force values 2, 1, 4, 0, 3 (table 6.4.7);
  // 105-byte pages at PLC address 128 (DB93) with the Communication Window at 240.
  setup({32, 32, 32, 9}, {32, 32, 32, 9}, true);
  const auto w = configure_all(kMotorTx, kMotorRx);
  EXPECT_EQ(w6(w), 5);
  const std::vector<std::uint8_t> d1 = {1, 2, 3, 4, 5, 6};
  auto values = [&](std::vector<std::uint8_t> forces, std::vector<std::uint8_t> m1) {
    std::map<std::size_t, std::pair<std::uint8_t, std::vector<std::uint8_t>>> v;
    for (std::size_t i = 0; i < 5; ++i) v[i] = {forces[i], i == 0 ? m1 : d1};
    return v;
  };
  // Rotation 1: force 2 first time, 1 always, 4 change from "none", 0 never, 3 change from "none".
  // form B8 on 6 bytes: a b c d e f -> b a f e d c (docs/slots.md "Data exchange in normal mode").
  auto a = send(data_page(251, kMotorTx, values({2, 1, 4, 0, 3}, d1)));
  EXPECT_EQ(w6(a), 1);
  EXPECT_EQ(rec.take(),
            V({"201#020106050403", "303#020106050403", "304#020106050403", "308#020106050403"}));
  // Rotation 2, nothing changed: only force 1.
  send(data_page(251, kMotorTx, values({2, 1, 4, 0, 3}, d1)));
  EXPECT_EQ(rec.take(), V({"303#020106050403"}));
  // Motor 1's data change (force 2) sends once.
  send(data_page(251, kMotorTx, values({2, 1, 4, 0, 3}, {9, 9, 9, 9, 9, 8})));
  EXPECT_EQ(rec.take(), V({"201#090908090909", "303#020106050403"}));
  send(data_page(251, kMotorTx, values({2, 1, 4, 0, 3}, {9, 9, 9, 9, 9, 8})));
  EXPECT_EQ(rec.take(), V({"303#020106050403"}));
  // Motor 8 toggles 3 -> 4: sends once more; staying at 4 sends nothing; 4 -> 3 sends again.
  send(data_page(251, kMotorTx, values({2, 1, 4, 0, 4}, {9, 9, 9, 9, 9, 8})));
  EXPECT_EQ(rec.take(), V({"303#020106050403", "308#020106050403"}));
  send(data_page(251, kMotorTx, values({2, 1, 4, 0, 4}, {9, 9, 9, 9, 9, 8})));
  EXPECT_EQ(rec.take(), V({"303#020106050403"}));
  send(data_page(251, kMotorTx, values({2, 1, 4, 0, 3}, {9, 9, 9, 9, 9, 8})));
  EXPECT_EQ(rec.take(), V({"303#020106050403", "308#020106050403"}));
  // force 0 never sends, whatever the data.
  send(data_page(251, kMotorTx, values({0, 0, 0, 0, 0}, {7, 7, 7, 7, 7, 7})));
  EXPECT_TRUE(rec.take().empty());
}

TEST_F(PageModeTest, ForceTwoComparesWithLastDataSent) {
  setup({32}, {32});
  const std::vector<IdEntry> tx = {id11(0x123, 0, 1)};
  configure_all(tx, {});
  send(data_page(251, tx, {{0, {2, {0x01}}}}));
  send(data_page(251, tx, {{0, {0, {0x02}}}}));  // changed while force 0: nothing sent
  send(data_page(251, tx, {{0, {2, {0x02}}}}));  // differs from the last data *sent*: sent
  send(data_page(251, tx, {{0, {2, {0x02}}}}));
  EXPECT_EQ(rec.take(), V({"123#01", "123#02"}));
}

TEST_F(PageModeTest, ForceAboveFourIsStatusTwoButThePageIsProcessed) {
  setup({32}, {32});
  const std::vector<IdEntry> tx = {id11(0x123, 0, 1), id11(0x124, 0, 1)};
  const std::vector<IdEntry> rx = {id11(0x181, 0, 1)};
  configure_all(tx, rx);
  rx_frame("181#42");
  const auto a = send(data_page(251, tx, {{0, {5, {0x01}}}, {1, {1, {0x02}}}}));
  EXPECT_EQ(status(a), static_cast<int>(Status::BadEntry));
  EXPECT_EQ(bytes(a, 8, 2), "01 42");  // inputs still delivered
  EXPECT_EQ(rec.take(), V({"124#02"}));
  EXPECT_TRUE(log_has("force 5"));
}

TEST_F(PageModeTest, RxCountInFormAndZeroFill) {
  setup({32}, {32});
  const std::vector<IdEntry> rx = {id11(0x281, 0xB8, 6), {{0x1ABCDEF, true}, 0x00, 4}};
  configure_all({}, rx);
  rx_frame("281#020106050403");
  rx_frame("281#020106050403");
  rx_frame("01ABCDEF#11");        // short frame: rest zero
                                  // (docs/slots.md "Data exchange in normal mode")
  rx_frame("281#R6");             // remote frames never update
  rx_frame("00000281#FFFFFFFF");  // another identifier (29-bit kind)
  const auto a = send(blank(251));
  // Rx 1 at 8: count 2, B8 turns 02 01 06 05 04 03 back into 01 02 03 04 05 06; Rx 2 at 15.
  EXPECT_EQ(bytes(a, 8, 12), "02 01 02 03 04 05 06 01 11 00 00 00");
  EXPECT_EQ(w4(a), 2);
  for (int i = 0; i < 254; ++i) rx_frame("01ABCDEF#22");
  EXPECT_EQ(bytes(send(blank(251)), 15, 2), "FF 22");
  rx_frame("01ABCDEF#23");
  EXPECT_EQ(bytes(send(blank(251)), 15, 2), "00 23");  // count_in modulo 256
}

TEST_F(PageModeTest, FramesBeforeConfigurationCompleteAreIgnored) {
  setup({32}, {32});
  init();
  config(51, {});
  rx_frame("281#01");  // Rx configuration not complete yet
  config(151, {id11(0x281, 0, 1)});
  EXPECT_EQ(bytes(send(blank(251)), 8, 2), "00 00");
  rx_frame("281#02");
  EXPECT_EQ(bytes(send(blank(251)), 8, 2), "01 02");
}

TEST_F(PageModeTest, LaterRxEntryWins) {
  setup({32}, {32});
  configure_all({}, {id11(0x281, 0, 1), id11(0x281, 0, 1)});
  rx_frame("281#77");
  EXPECT_EQ(bytes(send(blank(251)), 8, 4), "00 00 01 77");  // manual §5.2.1
  EXPECT_TRUE(log_has("configured twice"));
}

TEST_F(PageModeTest, ManyIdentifiersAcrossPages127Motors) {
  // 127 Tx + 127 Rx identifiers of 6 bytes through 32-byte segments (manual §6.4.1 example:
  // 127 motors), pages of 105 bytes as in manual §6.4.2 example 1: 12 entries per page.
  setup({32, 32, 32, 9}, {32, 32, 32, 9}, true);
  std::vector<IdEntry> tx, rx;
  for (std::uint32_t m = 1; m <= 127; ++m) {
    tx.push_back(id11(0x200 + m, 0xB8, 6));
    rx.push_back(id11(0x280 + m, 0xB8, 6));
  }
  configure_all(tx, rx);
  const auto places = page::pack_data(out, tx);
  const std::size_t pages = page::pages_used(places);
  EXPECT_EQ(pages, 11u);  // ceil(127 / 12): an entry never straddles two segments
  for (std::uint32_t m = 1; m <= 127; ++m) {
    char f[32];
    std::snprintf(f, sizeof f, "%03X#%02X%02X000000%02X", 0x280 + m, m, 0x01, 0xAA);
    rx_frame(f);
  }
  std::set<std::string> seen;
  for (std::size_t p = 0; p < pages; ++p) {
    std::map<std::size_t, std::pair<std::uint8_t, std::vector<std::uint8_t>>> v;
    for (std::size_t i = 0; i < tx.size(); ++i)
      if (places[i].page == p)
        v[i] = {1, {static_cast<std::uint8_t>(i), 0, 0, 0, 0, static_cast<std::uint8_t>(i + 1)}};
    const auto a = send(data_page(static_cast<std::uint16_t>(251 + p), tx, v));
    EXPECT_EQ(status(a), 0);
    EXPECT_EQ(w6(a), 11);
    const auto rxp = page::pack_data(in, rx);
    for (std::size_t i = 0; i < rx.size(); ++i) {
      if (rxp[i].page != p) continue;
      // count_in 1; B8: CAN m 01 00 00 00 AA -> PLC 01 m AA 00 00 00
      char want[64];
      std::snprintf(want, sizeof want, "01 01 %02X AA 00 00 00", static_cast<unsigned>(i + 1));
      EXPECT_EQ(bytes(a, rxp[i].offset, 7), want) << "Rx " << i;
    }
    for (auto& s : rec.take()) seen.insert(s);
  }
  EXPECT_EQ(seen.size(), 127u);  // every identifier's data reached the bus
  // Entry 1 = 0x201, data 00 00 00 00 00 01, form B8: b a f e d c.
  EXPECT_EQ(seen.count("201#000001000000"), 1u);
  EXPECT_EQ(seen.count("27F#007E7F000000"), 1u);
}

// ------------------------------------------------------------------ segment layout (Cfg code 9)

TEST_F(PageModeTest, FirstOutputSegmentMustHoldTheHeader) {
  // docs/page-mode.md "Segments": bytes 2-7 of the first segment are the header.
  EXPECT_FALSE(configure(page_prm(), segments_cfg({7}, {32})));
  const auto d = diag();
  EXPECT_EQ(d[8], 0x3E);
  EXPECT_EQ(d[9], 0);
  EXPECT_EQ(d[10], kCfgPageLayout);
  EXPECT_TRUE(configure(page_prm(), segments_cfg({8}, {32})));
}

// ------------------------------------------------------------------ engine without a gateway

struct FakeTx : TxPort {
  bool active = false;
  std::vector<std::string> sent;
  bool tx_active() const override { return active; }
  void transmit(const can::Frame& f) override { sent.push_back(can::format_candump(f)); }
};

TEST(PageModeEngine, SendsHeldUntilReleaseGoOutThen) {
  SlotConfig cfg;
  Slot o;
  o.kind = SlotKind::SegmentOut;
  o.length = 32;
  Slot i = o;
  i.kind = SlotKind::SegmentIn;
  cfg.slots = {o, i};
  PageMode pm;
  pm.configure(cfg);
  FakeTx tx;
  const Layout l({32});
  std::vector<std::uint8_t> p(32, 0);
  std::uint8_t seq = 0;
  auto push = [&](std::uint16_t n) {
    page::put_page_number(l, p, n);
    p[2] = ++seq;
    pm.on_output_page(p, Time{0}, tx);
  };
  push(0);
  const std::vector<IdEntry> tx_ids = {id11(0x321, 0, 1)};
  page::encode_config_page(l, tx_ids, p);
  push(51);
  page::encode_config_page(l, std::span<const IdEntry>{}, p);
  push(151);
  ASSERT_EQ(pm.state(), PageMode::State::Data);
  std::fill(p.begin() + 8, p.end(), 0);
  p[8] = page::kForceToggleA;
  p[9] = 0x5A;
  push(251);
  EXPECT_TRUE(tx.sent.empty());  // not released: held
  tx.active = true;
  pm.on_release(Time{0}, tx);
  EXPECT_EQ(tx.sent, (std::vector<std::string>{"321#5A"}));
  pm.on_release(Time{0}, tx);  // nothing held any more
  EXPECT_EQ(tx.sent.size(), 1u);
}

}  // namespace
}  // namespace candp2::gw::test

// Fuzzes Page-Mode page decoding: the page wire format and the gateway's page engine,
// alone and inside a whole gateway, driven by a byte script.
//
// Script: byte 0 = number of output segments (1..8), byte 1 = number of input segments (1..8),
// byte 2/3 = length of the last output/input segment (the others are 32, manual table 6.4.1); a
// layout decode_slots rejects ends the run. Then operations, each an op byte and its operands:
//   0: a raw output page (the bytes as they come),
//   1: a page with a consistent page number and sequence number, random payload,
//   2: a Tx/Rx configuration page built from script entries with the real encoder,
//   3: a data page for page 251 + n,
//   4: a CAN frame,
//   5: release (held sends go out).
// Invariants: no crash or sanitizer report; decode(encode(entries)) gives the entries back; every
// answered input page carries one page number in all its segments, status 0..4, the sequence
// number of the page it answers; only valid CAN frames are transmitted; N <= 65285; the gateway
// stays in Data_Exch.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "gateway/gateway.hpp"
#include "gateway/page_mode.hpp"

using namespace candp2;
namespace page = gw::page;

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

bool valid_frame(const can::Frame& f) {
  if (f.dlc > can::kMaxDlc || f.remote) return false;
  if (f.id > (f.extended ? can::kMaxExtId : can::kMaxStdId)) return false;
  for (std::size_t i = f.dlc; i < f.data.size(); ++i)
    if (f.data[i] != 0) return false;
  return true;
}

struct Port : gw::TxPort {
  bool active = true;
  std::uint64_t sent = 0;
  bool tx_active() const override { return active; }
  void transmit(const can::Frame& f) override {
    check(valid_frame(f));
    ++sent;
  }
};

struct CheckingSink : can::FrameSink {
  void send(const can::Frame& f) override { check(valid_frame(f)); }
};

struct Script {
  std::span<const std::uint8_t> bytes;
  std::size_t pos = 0;
  bool done() const { return pos >= bytes.size(); }
  std::uint8_t u8() { return pos < bytes.size() ? bytes[pos++] : 0; }
  std::uint16_t u16() { return static_cast<std::uint16_t>((u8() << 8) | u8()); }
};

page::IdEntry entry_from(Script& s) {
  page::IdEntry e;
  const std::uint8_t k = s.u8();
  e.id.extended = k & 0x80;
  const std::uint32_t v = (std::uint32_t{s.u16()} << 16) | s.u16();
  e.id.id = e.id.extended ? v & can::kMaxExtId : v & can::kMaxStdId;
  e.form = s.u8();
  e.length = static_cast<std::uint8_t>(1 + (k & 7));
  return e;
}

void round_trip(const page::Layout& out, Script& s) {
  std::vector<page::IdEntry> entries(s.u8() % 40);
  for (auto& e : entries) e = entry_from(s);
  std::vector<std::uint8_t> p(out.size(), 0);
  const std::size_t n = page::encode_config_page(out, entries, p);
  check(n <= entries.size());
  page::ConfigPageFault f;
  const auto d = page::decode_config_page(out, p, &f);
  if (!d) {
    // Only a page too small for even the marker has none.
    check(out.regions().empty() || out.max_entry() < page::kMarkerLen);
    return;
  }
  check(d->entries.size() == n);
  check(d->complete == (n == entries.size()));
  for (std::size_t i = 0; i < n; ++i) check(d->entries[i] == entries[i]);
}

void check_answer(const gw::PageMode& pm, std::span<const std::uint8_t> in, std::uint8_t seq) {
  const auto& layout = pm.input_layout();
  check(layout.size() == in.size());
  if (!pm.last_status()) return;  // nothing answered since the last reset
  check(page::page_number(layout, in).has_value());
  check(in[page::kStatusByte] <= 4);
  check(in[page::kSeqByte] == seq);
  check(pm.data_pages() <= page::kMaxDataPages);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Script s{{data, size}};
  const std::size_t n_out = 1 + s.u8() % 8, n_in = 1 + s.u8() % 8;
  const std::size_t last_out = 1 + s.u8() % 32, last_in = 1 + s.u8() % 32;
  std::vector<dp::CfgEntry> entries;
  std::vector<std::size_t> outs, ins;
  for (std::size_t i = 0; i < n_out; ++i) outs.push_back(i + 1 == n_out ? last_out : 32);
  for (std::size_t i = 0; i < n_in; ++i) ins.push_back(i + 1 == n_in ? last_in : 32);
  for (auto n : outs) entries.push_back(dp::special_output(static_cast<std::uint8_t>(n), true, {}));
  for (auto n : ins) entries.push_back(dp::special_input(static_cast<std::uint8_t>(n), true, {}));
  gw::UserPrm prm;
  prm.page_mode = true;
  const auto cfg_bytes = dp::encode_chk_cfg(entries);
  auto decoded = gw::decode_slots(cfg_bytes, prm);
  if (!std::holds_alternative<gw::SlotConfig>(decoded)) return 0;
  const auto& cfg = std::get<gw::SlotConfig>(decoded);

  // The engine alone.
  gw::PageMode pm;
  pm.configure(cfg);
  const page::Layout out = pm.output_layout();
  check(out.size() == cfg.output_len && pm.input_layout().size() == cfg.input_len);
  // The same script through a whole gateway.
  CheckingSink sink;
  gw::Gateway gateway({}, sink, Time{0});
  const auto set_prm = gw::make_set_prm(prm);
  gateway.dp().set_prm(1, set_prm, Time{0});
  gateway.dp().chk_cfg(1, cfg_bytes, Time{0});
  check(gateway.dp().state() == dp::SlaveState::DataExch);

  Port port;
  std::vector<std::uint8_t> p(out.size());
  std::vector<std::uint8_t> in(pm.input_page_len());
  std::uint8_t seq = 0;
  std::optional<std::uint8_t> answered;  // sequence number of the last processed page
  Time now{0};
  int ops = 0;
  while (!s.done() && ++ops < 2000) {
    now += milliseconds(1);
    const std::uint8_t op = s.u8() % 6;
    bool page_op = true;
    switch (op) {
      case 0:
        for (auto& b : p) b = s.u8();
        break;
      case 1: {
        for (auto& b : p) b = s.u8();
        page::put_page_number(out, p, s.u16());
        p[page::kSeqByte] = ++seq;
        break;
      }
      case 2: {
        const std::uint8_t k = s.u8();
        const std::uint16_t number = static_cast<std::uint16_t>(
            (k & 1 ? page::kRxConfigFirst : page::kTxConfigFirst) + (k >> 1) % 4);
        std::vector<page::IdEntry> list(s.u8() % 12);
        for (auto& e : list) e = entry_from(s);
        std::fill(p.begin(), p.end(), 0);
        page::encode_config_page(out, list, p);
        page::put_page_number(out, p, s.u8() % 8 == 0 ? 0 : number);
        p[page::kSeqByte] = ++seq;
        break;
      }
      case 3: {
        for (auto& b : p) b = s.u8() % 8;  // mostly valid force values
        page::put_page_number(out, p, static_cast<std::uint16_t>(page::kDataFirst + s.u8() % 4));
        p[page::kSeqByte] = ++seq;
        break;
      }
      case 4: {
        page_op = false;
        can::Frame f;
        const std::uint8_t k = s.u8();
        f.extended = k & 0x80;
        f.remote = k & 0x40;
        f.dlc = static_cast<std::uint8_t>(k % 9);
        const std::uint32_t v = (std::uint32_t{s.u16()} << 16) | s.u16();
        f.id = f.extended ? v & can::kMaxExtId : v & can::kMaxStdId;
        if (!f.remote)
          for (std::size_t i = 0; i < f.dlc; ++i) f.data[i] = s.u8();
        pm.on_frame(f, now);
        gateway.on_can_frame(f, now);
        break;
      }
      case 5:
        page_op = false;
        port.active = !port.active;
        pm.on_release(now, port);
        round_trip(out, s);
        break;
    }
    if (!page_op) continue;
    const auto number = page::page_number(out, p);
    const bool fresh = number && (!answered || *answered != p[page::kSeqByte]);
    pm.on_output_page(p, now, port);
    if (fresh) answered = p[page::kSeqByte];
    pm.write_input_page(in);
    if (answered) check_answer(pm, in, *answered);
    // Through the gateway: its output image is the page (no CW).
    auto reply = gateway.dp().data_exchange(1, p, now);
    check(reply.has_value() && reply->size() == in.size());
    check(std::equal(reply->begin(), reply->end(), in.begin()));
  }
  return 0;
}

// Fuzzes the FDL stream parser and the FDL slave front end serving real gateways
// (docs/profibus.md). Byte 0 selects the mode: even = the rest is a raw line stream, cut into
// chunks (with gaps) by byte 1; odd = the rest is a list of telegram records encoded with a valid
// FCS, so the front end's DP services are reached. Every decoded telegram goes to the front end.
// Invariants: no crash or sanitizer report; every telegram the parser emits re-decodes from its
// raw bytes to the same value; every byte fed is counted and a final gap leaves nothing buffered;
// every response decodes as a valid telegram addressed back to the requester, not before the
// request's end; an SRD with FCV=1 sent again gets byte-identical bytes (repetition).
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <span>
#include <vector>

#include "gateway/gateway.hpp"
#include "profibus_sim/fdl/fdl.hpp"
#include "profibus_sim/fdl/fdl_describe.hpp"
#include "profibus_sim/fdl/fdl_slave.hpp"

using namespace candp2;

namespace {

struct NullSink : can::FrameSink {
  void send(const can::Frame&) override {}
};

void check(bool ok) {
  if (!ok) std::abort();
}

struct Harness {
  NullSink sink;
  gw::Gateway g3{{.address = 3}, sink, Time{0}};
  gw::Gateway g4{{.address = 4}, sink, Time{0}};
  fdl::SlaveFrontEnd fe{fdl::SlaveFrontEndOptions{}, nullptr};
  fdl::Describer describer;
  Time now{0};

  Harness() {
    check(fe.add(g3.dp()));
    check(fe.add(g4.dp()));
  }

  void reply_checks(const fdl::Telegram& req, const std::optional<fdl::Reply>& r) {
    if (!r) return;
    check(r->not_before >= now);
    const auto d = fdl::decode(r->bytes);
    check(d.error == fdl::Error::None && d.telegram);
    const fdl::Telegram& rsp = *d.telegram;
    if (rsp.kind != fdl::Kind::SC) {
      check(!rsp.is_request());
      check(rsp.da == req.sa && rsp.sa == req.da);
    }
    (void)fdl::describe(rsp, &req);
  }

  void serve(const fdl::Telegram& t) {
    now += microseconds(700);
    (void)describer.describe(t);
    const auto r = fe.on_telegram(t, now);
    reply_checks(t, r);
    // A repetition (same FCB, FCV=1) returns the identical bytes without executing.
    const bool srd = t.function() == fdl::kFcSrdLow || t.function() == fdl::kFcSrdHigh;
    if (r && t.is_request() && t.fcv() && srd && t.kind != fdl::Kind::SD4) {
      const auto again = fe.on_telegram(t, now);
      check(again && again->bytes == r->bytes);
    }
    g3.advance(now);
    g4.advance(now);
  }

  void drain(fdl::StreamParser& p) {
    while (auto ev = p.next()) {
      if (ev->error != fdl::Error::None) {
        check(!ev->raw.empty());
        continue;
      }
      const auto again = fdl::decode(ev->raw);
      check(again.error == fdl::Error::None && again.telegram == ev->telegram);
      serve(ev->telegram);
    }
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  Harness h;
  fdl::StreamParser parser;
  std::uint64_t fed = 0;
  if ((data[0] & 1) == 0) {
    // Raw stream: chunk sizes 1..16 from a small LCG seeded by byte 1; a gap after some chunks.
    std::uint32_t x = data[1] | 0x100u;
    std::size_t pos = 2;
    while (pos < size) {
      x = x * 1103515245u + 12345u;
      const std::size_t n = std::min<std::size_t>(1 + ((x >> 16) & 15), size - pos);
      if ((x >> 8) & 1) {
        parser.feed(std::span(data + pos, n));
      } else {
        for (std::size_t i = 0; i < n; ++i) {
          if (((x >> (i & 15)) & 0x1F) == 0)
            parser.feed_bad_char(data[pos + i]);
          else
            parser.feed(data[pos + i]);
        }
      }
      fed += n;
      pos += n;
      h.drain(parser);
      if (((x >> 24) & 7) == 0) {
        parser.gap();
        h.drain(parser);
      }
    }
  } else {
    // Records: kind, da, sa, fc, sap flags, dsap, ssap, length, data...
    std::size_t pos = 1;
    while (pos + 8 <= size) {
      const std::uint8_t* r = data + pos;
      fdl::Telegram t;
      const std::size_t len = std::min<std::size_t>(r[7], size - pos - 8);
      std::vector<std::uint8_t> du(r + 8, r + 8 + len);
      pos += 8 + len;
      const auto dsap = (r[4] & 1) ? std::optional<std::uint8_t>(r[5] & 0x3F) : std::nullopt;
      const auto ssap = (r[4] & 2) ? std::optional<std::uint8_t>(r[6] & 0x3F) : std::nullopt;
      // Steer towards the served stations and a master's request codes.
      const std::uint8_t da = (r[4] & 4) ? static_cast<std::uint8_t>(r[1] & 0x7F)
                                         : static_cast<std::uint8_t>(3 + (r[1] & 1));
      const std::uint8_t sa = r[2] & 0x7F;
      switch (r[0] % 5) {
        case 0:
          t = fdl::Telegram::no_data(da, sa, r[3]);
          break;
        case 1:
          t = fdl::Telegram::sc();
          break;
        case 2:
          t = fdl::Telegram::token(da, sa);
          break;
        default:
          t = fdl::Telegram::with_data(da, sa, r[3], dsap, ssap, std::move(du));
          break;
      }
      const auto bytes = fdl::encode(t);
      if (bytes.empty()) continue;  // not encodable (e.g. SD2 without data)
      parser.feed(bytes);
      fed += bytes.size();
      h.drain(parser);
    }
  }
  parser.gap();
  h.drain(parser);
  check(parser.buffered() == 0);
  check(parser.stats().bytes == fed);
  return 0;
}

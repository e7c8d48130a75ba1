// Fuzzes the pcapng reader (capture/pcapng_read.hpp) and the line statistics
// (profibus_sim/fdl/line_stats.hpp) the way `candp2 sniff --stats` uses them on a capture a user
// hands it (docs/sniff.md "Line statistics: --stats"): the input is a capture file; every packet
// of a PROFIBUS interface is observed as a telegram at its time stamp, and the input is also fed
// as telegrams cut by its own bytes. Invariants: no crash or sanitizer report; a capture is ok
// exactly when it names no error; every packet's interface exists; the statistics list each
// station once, in order, and count no more valid telegrams than were observed.
#include <cstdint>
#include <cstdlib>
#include <span>

#include "capture/pcapng.hpp"
#include "capture/pcapng_read.hpp"
#include "profibus_sim/fdl/line_stats.hpp"

using namespace candp2;

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> in(data, size);
  namespace pc = capture::pcapng;
  const pc::Capture c = pc::read(in);
  check(c.ok == c.error.empty());
  fdl::LineStatistics stats;
  std::uint64_t observed = 0;
  for (const pc::Packet& p : c.packets) {
    check(p.interface < c.interfaces.size());
    const pc::Interface& i = c.interfaces[p.interface];
    const Time t(static_cast<std::int64_t>(pc::time_ns(i, p.time).value_or(0) / 1000));
    std::span<const std::uint8_t> telegram = p.data;
    if (i.linktype == pc::kLinktypeWiresharkUpperPdu) {
      const auto e = pc::parse_exported_pdu(p.data);
      if (!e) continue;
      check(e->pdu.data() >= p.data.data() &&
            e->pdu.data() + e->pdu.size() <= p.data.data() + p.data.size());
      telegram = e->pdu;
    }
    stats.observe(telegram, t);
    ++observed;
  }
  // The raw bytes as telegrams: byte k's low 4 bits give the length of the next one.
  for (std::size_t at = 0; at < size;) {
    const std::size_t n = std::min<std::size_t>(size - at, (data[at] & 0x0F) + 1);
    if (data[at] == 0xFF) stats.observe_illegal(Time(static_cast<std::int64_t>(at)));
    stats.observe(in.subspan(at, n), Time(static_cast<std::int64_t>(at)));
    ++observed;
    at += n;
  }
  check(stats.telegrams() <= observed);
  const auto st = stats.stations();
  for (std::size_t k = 1; k < st.size(); ++k) check(st[k - 1] < st[k]);
  check(stats.rotation().min <= stats.rotation().max);
  return 0;
}

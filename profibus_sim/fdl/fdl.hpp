// PROFIBUS FDL (layer 2, IEC 61158-4-3 type 3 / EN 50170 vol. 2) telegrams on the wire: the start
// delimiters, frame control, address extensions (SAPs), the frame check sequence, a codec for one
// telegram and a stream parser that finds telegrams in a byte stream that may start mid-telegram or
// carry noise. Pure: bytes in, telegrams/bytes out, no I/O, no clock (docs/profibus.md).
// Names follow the standard's abbreviations.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace candp2::fdl {

// ---- Start/end delimiters (docs/profibus.md "Telegrams") -------------------------------------
inline constexpr std::uint8_t kSD1 = 0x10;  // no data unit: SD1 DA SA FC FCS ED
inline constexpr std::uint8_t kSD2 = 0x68;  // variable: SD2 LE LEr SD2 DA SA FC DU FCS ED
inline constexpr std::uint8_t kSD3 = 0xA2;  // fixed 8-byte data unit: SD3 DA SA FC DU(8) FCS ED
inline constexpr std::uint8_t kSD4 = 0xDC;  // token: SD4 DA SA
inline constexpr std::uint8_t kSC = 0xE5;   // short acknowledge (single character)
inline constexpr std::uint8_t kED = 0x16;   // end delimiter

// LE of SD2 = number of bytes DA, SA, FC, DSAP/SSAP and DU (docs/profibus.md). IEC 61158-4-3
// sends 4..249 (at least one data-unit byte; SD1 is the telegram without data); on receive 3..249
// is accepted like pyprofibus fdl.py and profirust telegram.rs do
// (docs/decisions.md "FDL on the wire").
inline constexpr std::size_t kLeMin = 4;
inline constexpr std::size_t kLeMinRx = 3;
inline constexpr std::size_t kLeMax = 249;
inline constexpr std::size_t kMaxDataUnit = kLeMax - 3;     // DSAP/SSAP + DU bytes of an SD2
inline constexpr std::size_t kSd3DataLen = 8;               // SD3: exactly 8 DU bytes (incl. SAPs)
inline constexpr std::size_t kMaxTelegramLen = kLeMax + 6;  // SD2 LE LEr SD2 ... FCS ED

// ---- Addresses (docs/profibus.md) -------------------------------------------------------------
inline constexpr std::uint8_t kAddrExt = 0x80;     // DA/SA bit 7: a SAP byte follows FC
inline constexpr std::uint8_t kAddrMask = 0x7F;    // station address 0..127
inline constexpr std::uint8_t kBroadcast = 127;    // global address: nobody answers
inline constexpr std::uint8_t kSapMask = 0x3F;     // bits 5..0 of a SAP (address extension) byte
inline constexpr std::uint8_t kSapExtMask = 0xC0;  // bits 7..6: segment/further extension (unused)

// DP service access points (EN 50170 vol. 2 DP; docs/profibus.md "DP services over FDL").
inline constexpr std::uint8_t kSapMasterMaster = 54;  // MM services (class 2)
inline constexpr std::uint8_t kSapSetSlaveAdd = 55;
inline constexpr std::uint8_t kSapRdInp = 56;
inline constexpr std::uint8_t kSapRdOutp = 57;
inline constexpr std::uint8_t kSapGlobalControl = 58;
inline constexpr std::uint8_t kSapGetCfg = 59;
inline constexpr std::uint8_t kSapSlaveDiag = 60;
inline constexpr std::uint8_t kSapSetPrm = 61;
inline constexpr std::uint8_t kSapChkCfg = 62;  // also the master's SSAP for all DP services

// ---- Frame control (docs/profibus.md "Frame control") -----------------------------------------
inline constexpr std::uint8_t kFcReq = 0x40;              // bit 6: request (1) / response (0)
inline constexpr std::uint8_t kFcFcb = 0x20;              // request bit 5: frame count bit
inline constexpr std::uint8_t kFcFcv = 0x10;              // request bit 4: frame count bit valid
inline constexpr std::uint8_t kFcStationTypeMask = 0x30;  // response bits 5..4
inline constexpr std::uint8_t kFcFuncMask = 0x0F;         // bits 3..0

// Request function codes (bits 3..0 with bit 6 set).
inline constexpr std::uint8_t kFcTimeEvent = 0x0;  // clock synchronisation
inline constexpr std::uint8_t kFcSdaLow = 0x3;
inline constexpr std::uint8_t kFcSdnLow = 0x4;
inline constexpr std::uint8_t kFcSdaHigh = 0x5;
inline constexpr std::uint8_t kFcSdnHigh = 0x6;
inline constexpr std::uint8_t kFcMsrd = 0x7;
inline constexpr std::uint8_t kFcFdlStatus = 0x9;  // Request FDL Status (SD1 FC 0x49)
inline constexpr std::uint8_t kFcSrdLow = 0xC;
inline constexpr std::uint8_t kFcSrdHigh = 0xD;
inline constexpr std::uint8_t kFcIdent = 0xE;       // Request Ident with reply
inline constexpr std::uint8_t kFcLsapStatus = 0xF;  // Request LSAP status with reply

// Response function codes (bits 3..0 with bit 6 clear).
inline constexpr std::uint8_t kFcOk = 0x0;   // acknowledgement positive
inline constexpr std::uint8_t kFcUe = 0x1;   // user error
inline constexpr std::uint8_t kFcRr = 0x2;   // no resource
inline constexpr std::uint8_t kFcRs = 0x3;   // no service activated (SAP not active)
inline constexpr std::uint8_t kFcDl = 0x8;   // response data low
inline constexpr std::uint8_t kFcNr = 0x9;   // no response data
inline constexpr std::uint8_t kFcDh = 0xA;   // response data high (diagnosis pending)
inline constexpr std::uint8_t kFcRdl = 0xC;  // response data low, resource not available
inline constexpr std::uint8_t kFcRdh = 0xD;  // response data high, resource not available

// Station type of a response (bits 5..4): FDL_Status answers carry it.
inline constexpr std::uint8_t kStationSlave = 0x00;
inline constexpr std::uint8_t kStationMasterNotReady = 0x10;
inline constexpr std::uint8_t kStationMasterReady = 0x20;   // ready, not in the logical ring
inline constexpr std::uint8_t kStationMasterInRing = 0x30;  // ready, in the logical ring

// Builds an FC byte.
constexpr std::uint8_t request_fc(std::uint8_t function, bool fcb = false, bool fcv = false) {
  return static_cast<std::uint8_t>(kFcReq | (fcb ? kFcFcb : 0) | (fcv ? kFcFcv : 0) |
                                   (function & kFcFuncMask));
}
constexpr std::uint8_t response_fc(std::uint8_t function,
                                   std::uint8_t station_type = kStationSlave) {
  return static_cast<std::uint8_t>((station_type & kFcStationTypeMask) | (function & kFcFuncMask));
}

// ---- Telegram value type ---------------------------------------------------------------------
enum class Kind : std::uint8_t { SD1, SD2, SD3, SD4, SC };
std::string_view to_string(Kind k);

struct Telegram {
  Kind kind = Kind::SD1;
  std::uint8_t da = 0;  // destination address 0..127 (without the extension bit)
  std::uint8_t sa = 0;  // source address 0..127 (without the extension bit)
  std::uint8_t fc = 0;  // frame control (SD1/SD2/SD3)
  // Address extensions (SD2/SD3 only): DSAP present sets DA bit 7, SSAP present sets SA bit 7.
  std::optional<std::uint8_t> dsap;
  std::optional<std::uint8_t> ssap;
  std::vector<std::uint8_t> du;  // the data unit after the SAP bytes

  bool is_request() const { return fc & kFcReq; }
  bool fcb() const { return fc & kFcFcb; }
  bool fcv() const { return fc & kFcFcv; }
  std::uint8_t function() const { return fc & kFcFuncMask; }

  // Factories for the common shapes.
  static Telegram sc() {
    Telegram t;
    t.kind = Kind::SC;
    return t;
  }
  static Telegram token(std::uint8_t da, std::uint8_t sa) {
    Telegram t;
    t.kind = Kind::SD4;
    t.da = da;
    t.sa = sa;
    return t;
  }
  static Telegram no_data(std::uint8_t da, std::uint8_t sa, std::uint8_t fc) {
    Telegram t;
    t.da = da;
    t.sa = sa;
    t.fc = fc;
    return t;
  }
  // SD2, or SD3 when SAP bytes + data are exactly 8 bytes.
  static Telegram with_data(std::uint8_t da, std::uint8_t sa, std::uint8_t fc,
                            std::optional<std::uint8_t> dsap, std::optional<std::uint8_t> ssap,
                            std::vector<std::uint8_t> du);
  // The same shapes into this telegram, its data unit's storage kept (no allocation once it has
  // held as many bytes): for a line that builds one telegram after the other.
  void assign(Kind k, std::uint8_t d, std::uint8_t s, std::uint8_t f);  // SD1, SD4, SC: no data
  void assign_with_data(std::uint8_t d, std::uint8_t s, std::uint8_t f,
                        std::optional<std::uint8_t> dsap_, std::optional<std::uint8_t> ssap_,
                        std::span<const std::uint8_t> data);

  friend bool operator==(const Telegram&, const Telegram&) = default;
};

// Frame check sequence: arithmetic sum mod 256 of DA, SA, FC and the data unit incl. SAP bytes
// (docs/profibus.md) — i.e. of the bytes passed in.
std::uint8_t fcs(std::span<const std::uint8_t> bytes);

// Wire bytes of a telegram. Precondition (checked; violated → empty vector): addresses ≤ 127,
// SAPs ≤ 63; SD1 has no SAPs/DU; SD2 has 1..246 SAP+DU bytes; SD3 has exactly 8 SAP+DU bytes.
std::vector<std::uint8_t> encode(const Telegram& t);
void encode_to(const Telegram& t, std::vector<std::uint8_t>& out);  // appends; same rules

// ---- Decoding one telegram ---------------------------------------------------------------------
enum class Error : std::uint8_t {
  None,
  Empty,          // no bytes
  BadStart,       // first byte is no start delimiter
  Truncated,      // the telegram ended before its last byte (or a gap cut it)
  LeOutOfRange,   // SD2: LE not 4..249
  LeMismatch,     // SD2: LE != LEr
  BadSd2Repeat,   // SD2: the 4th byte is not 0x68
  BadFcs,         // frame check sequence wrong
  MissingEd,      // no 0x16 where the end delimiter belongs
  SapMissing,     // DA/SA bit 7 set but the data unit has no room for the SAP byte
  BadSap,         // SAP byte with bits 7..6 set (segment addresses are not supported)
  ParityError,    // a character of the telegram had a parity error (stream parser only)
  TrailingBytes,  // decode(): bytes after the end delimiter
};
std::string_view to_string(Error e);

struct DecodeResult {
  std::optional<Telegram> telegram;
  Error error = Error::None;
  std::size_t length = 0;  // bytes the telegram occupies (when decoded)
};

// Decodes exactly one telegram spanning all of `bytes`.
DecodeResult decode(std::span<const std::uint8_t> bytes);

// ---- Stream parser -----------------------------------------------------------------------------
struct ParserStats {
  std::uint64_t telegrams = 0;
  std::uint64_t fcs_errors = 0;
  std::uint64_t framing_errors = 0;  // LE/LEr, SD2 repeat, missing ED, truncated, SAP errors
  std::uint64_t parity_errors = 0;   // telegrams discarded for a character parity error
  std::uint64_t garbage_bytes = 0;   // bytes skipped while hunting for a start delimiter
  std::uint64_t bytes = 0;           // all bytes fed
};

struct ParserEvent {
  // A telegram (error == None) or an abandoned candidate (error != None, telegram unset).
  Telegram telegram;
  Error error = Error::None;
  std::uint64_t offset = 0;       // stream offset (bytes fed before it) of the first byte
  std::vector<std::uint8_t> raw;  // the telegram's (or the abandoned candidate's) bytes
};

// Fed arbitrary chunks; emits telegrams and error events in stream order. A candidate that turns
// out bad is abandoned and scanning resumes at the byte after its start delimiter, so a good
// telegram behind noise is found. Bytes outside any telegram are counted as garbage.
class StreamParser {
 public:
  void feed(std::span<const std::uint8_t> bytes);
  void feed(std::uint8_t byte) { feed(std::span<const std::uint8_t>(&byte, 1)); }
  // A character received with a parity (or framing) error: the telegram it belongs to is dropped.
  void feed_bad_char(std::uint8_t byte);
  // Idle ≥ TSYN (33 bit times) on the line, or end of input: a partial telegram is abandoned
  // (Error::Truncated) and everything buffered is resolved.
  void gap();

  bool has_event() const { return !events_.empty(); }
  std::optional<ParserEvent> next();  // pops the oldest event

  const ParserStats& stats() const { return stats_; }
  std::size_t buffered() const { return buf_.size(); }

 private:
  void scan(bool at_gap);
  void emit_error(Error e, std::span<const std::uint8_t> raw);

  std::vector<std::uint8_t> buf_;
  std::vector<bool> bad_;         // parity flag per buffered byte
  std::uint64_t buf_offset_ = 0;  // stream offset of buf_[0]
  std::deque<ParserEvent> events_;
  ParserStats stats_;
};

}  // namespace candp2::fdl

// pcapng blocks (the PCAP Next Generation capture file format, IETF draft-ietf-opsawg-pcapng;
// link types from the tcpdump.org LINKTYPE registry): the Section Header, Interface Description
// and Enhanced Packet blocks candp2's captures use, and the packet payloads of the link types we
// write (docs/capture.md). Pure: bytes out, no I/O. Every block is written little-endian (the
// Section Header's byte-order magic says so to readers).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "can/frame.hpp"
#include "can/virtual_bus.hpp"

namespace candp2::capture::pcapng {

// ---- Block types --------------------------------------------------------------------------
inline constexpr std::uint32_t kSectionHeaderBlock = 0x0A0D0D0A;
inline constexpr std::uint32_t kInterfaceDescriptionBlock = 0x00000001;
inline constexpr std::uint32_t kEnhancedPacketBlock = 0x00000006;
inline constexpr std::uint32_t kByteOrderMagic = 0x1A2B3C4D;

// ---- Options ------------------------------------------------------------------------------
inline constexpr std::uint16_t kOptEndOfOpt = 0;
inline constexpr std::uint16_t kOptComment = 1;
inline constexpr std::uint16_t kShbHardware = 2;
inline constexpr std::uint16_t kShbOs = 3;
inline constexpr std::uint16_t kShbUserAppl = 4;
inline constexpr std::uint16_t kIfName = 2;
inline constexpr std::uint16_t kIfDescription = 3;
inline constexpr std::uint16_t kIfSpeed = 8;    // the interface's speed in bit/s (u64)
inline constexpr std::uint16_t kIfTsresol = 9;  // value 9: time stamps in nanoseconds
inline constexpr std::uint16_t kEpbFlags = 2;

// ---- Link types (tcpdump.org LINKTYPE_ values) --------------------------------------------
// The 16-byte SocketCAN header and data (CAN ID and flags big-endian).
inline constexpr std::uint16_t kLinktypeCanSocketcan = 227;
// Wireshark's exported PDUs: tags naming the dissector, then the PDU (docs/decisions.md
// "pcapng captures").
inline constexpr std::uint16_t kLinktypeWiresharkUpperPdu = 252;
// PROFIBUS data link layer (IEC 61158-4-3): the telegram from start to end delimiter.
inline constexpr std::uint16_t kLinktypeProfibusDl = 257;

// SocketCAN can_id flags (linux/can.h, the values LINKTYPE_CAN_SOCKETCAN carries).
inline constexpr std::uint32_t kCanEffFlag = 0x80000000u;
inline constexpr std::uint32_t kCanRtrFlag = 0x40000000u;
inline constexpr std::size_t kSocketcanLen = 16;
// SocketCAN error frames (linux/can/error.h): the flag, the classes in can_id, DLC 8.
inline constexpr std::uint32_t kCanErrFlag = 0x20000000u;
inline constexpr std::uint32_t kCanErrCrtl = 0x004;       // data[1]: controller problems
inline constexpr std::uint32_t kCanErrProt = 0x008;       // data[2] type, data[3] location
inline constexpr std::uint32_t kCanErrAck = 0x020;        // received no ACK on transmission
inline constexpr std::uint32_t kCanErrBusoff = 0x040;     // bus off
inline constexpr std::uint32_t kCanErrRestarted = 0x100;  // controller restarted
inline constexpr std::uint8_t kCanErrCrtlRxWarning = 0x04, kCanErrCrtlTxWarning = 0x08,
                              kCanErrCrtlRxPassive = 0x10, kCanErrCrtlTxPassive = 0x20,
                              kCanErrCrtlActive = 0x40;
inline constexpr std::uint8_t kCanErrProtBit = 0x01, kCanErrProtStuff = 0x04, kCanErrProtTx = 0x80;
inline constexpr std::uint8_t kCanErrProtLocSof = 0x03, kCanErrProtLocCrcSeq = 0x08,
                              kCanErrProtLocAck = 0x19;

// Exported-PDU tags (Wireshark's wsutil/exported_pdu_tlvs.h, the format of LINKTYPE 252).
inline constexpr std::uint16_t kExpPduEndOfOpt = 0;
inline constexpr std::uint16_t kExpPduDissectorName = 12;
inline constexpr std::uint16_t kExpPduColProtText = 33;

// EPB flags bits 1..0: the packet's direction.
enum class Direction : std::uint8_t { Unknown = 0, Inbound = 1, Outbound = 2 };

// ---- Blocks -------------------------------------------------------------------------------
// One section, length unknown (-1); shb_userappl = application, shb_os = os (both optional).
std::vector<std::uint8_t> section_header(std::string_view application, std::string_view os = {});
// An interface: link type, if_name, if_description (optional), if_speed (bit/s, when not 0),
// if_tsresol = 9 (ns), snaplen 0 (no limit).
std::vector<std::uint8_t> interface_description(std::uint16_t linktype, std::string_view name,
                                                std::string_view description = {},
                                                std::uint64_t speed = 0);
// A packet on interface `interface_id` at `time_ns` (ns since the Unix epoch, as if_tsresol 9
// says), with epb_flags carrying the direction and an optional opt_comment. Appends to `out`.
void enhanced_packet(std::vector<std::uint8_t>& out, std::uint32_t interface_id,
                     std::uint64_t time_ns, std::span<const std::uint8_t> data, Direction direction,
                     std::string_view comment = {});

// ---- Payloads -----------------------------------------------------------------------------
// LINKTYPE_CAN_SOCKETCAN: can_id (with EFF/RTR flags) big-endian, length (for a remote frame
// the requested length), 3 bytes padding/reserved, 8 data bytes (zero past the length).
std::array<std::uint8_t, kSocketcanLen> socketcan(const can::Frame& frame);
// The same for an error on a bus in time (docs/capture.md "Error frames"): CAN_ERR_FLAG, DLC 8,
// the class bits and data bytes a SocketCAN controller gives, TEC and REC in data[6..7].
std::array<std::uint8_t, kSocketcanLen> socketcan_error(const can::BusError& error);
// LINKTYPE_WIRESHARK_UPPER_PDU: the dissector-name tag, optionally the protocol-column tag, the
// end tag, then the PDU. Appends to `out`.
void exported_pdu(std::vector<std::uint8_t>& out, std::string_view dissector,
                  std::span<const std::uint8_t> pdu, std::string_view protocol_column = {});

}  // namespace candp2::capture::pcapng

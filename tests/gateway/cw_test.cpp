// The Communication Window (manual §5.3, §8.2 FB4; docs/slots.md "Data exchange in normal mode",
// docs/communication-window.md).
#include <gtest/gtest.h>

#include <cctype>

#include "fixture.hpp"
#include "gateway/comm_window.hpp"

namespace candp2::gw::test {
namespace {

// manual §5.3.4 step 1.2: one CW per direction, 16 bytes, consistent, identifier FF EF, form 00.
const std::vector<std::uint8_t> kCwCfg =
    cfg_of({in_slot(16, {0xFF, 0xEF, 0x00}), out_slot(16, {0xFF, 0xEF, 0x00})});

UserPrm cw_prm() {
  UserPrm p;
  p.comm_window = true;  // manual §5.3.4 step 1.1
  return p;
}

// 16 bytes written as in the manual's tables: "00 12 00 00 ...".
std::array<std::uint8_t, kCwLen> window(const char* hex_text) {
  std::array<std::uint8_t, kCwLen> w{};
  std::size_t n = 0;
  for (const char* p = hex_text; *p;) {
    if (*p == ' ') {
      ++p;
      continue;
    }
    if (n == kCwLen || !std::isxdigit(p[0]) || !std::isxdigit(p[1])) {
      ADD_FAILURE() << "bad window text: " << hex_text;
      return w;
    }
    w[n++] = static_cast<std::uint8_t>(std::stoi(std::string(p, 2), nullptr, 16));
    p += 2;
  }
  EXPECT_EQ(n, kCwLen) << hex_text;
  return w;
}

class CommWindowTest : public GatewayFixture {
 protected:
  bool setup(const UserPrm& p = cw_prm(), const std::vector<std::uint8_t>& cfg = kCwCfg) {
    if (!configure(p, cfg)) return false;
    out_.assign(gw->slot_config()->output_len, 0);
    return true;
  }
  const Slot& slot(std::optional<std::size_t> index) const {
    return gw->slot_config()->slots.at(index.value());
  }
  // Puts the 16 bytes into the CW output slot, runs one Data_Exchange, returns the read window.
  std::string write(const std::array<std::uint8_t, kCwLen>& w) {
    std::copy(w.begin(), w.end(), out_.begin() + slot(gw->slot_config()->cw_out).offset);
    return poll();
  }
  // Input bytes 0-1 after one more Data_Exchange.
  std::string slot_bytes() {
    const auto in = exchange(out_);
    return hex(std::span(in).first(2));
  }
  // One more Data_Exchange with unchanged outputs (the PLC polling, manual §5.3.4.2 step 2.3).
  std::string poll() {
    in_ = exchange(out_);
    return hex(std::span(in_).subspan(slot(gw->slot_config()->cw_in).offset, kCwLen));
  }
  // A command with the next loop counter (manual §5.3.4 step 1.3).
  std::string command(std::uint8_t cmd, can::Ident id = {}, std::vector<std::uint8_t> data = {},
                      std::optional<std::uint8_t> length = {}, std::uint8_t sub = 0) {
    CwRequest r;
    r.command = cmd;
    r.set_identifier(id);
    std::copy(data.begin(), data.end(), r.data.begin());
    r.length = length.value_or(static_cast<std::uint8_t>(data.size()));
    r.counter = ++counter_;
    r.sub_command = sub;
    return write(encode_cw_request(r));
  }
  // Byte 15 of the read window after `command`.
  int error_of(const std::string& read) { return std::stoi(read.substr(45, 2), nullptr, 16); }
  // A read window without a frame, with the echo of counter and sub-command and an error code.
  static std::string idle(std::uint8_t counter, std::uint8_t sub = 0, std::uint8_t error = 0) {
    return "EE EE 00 00 00 00 00 00 00 00 00 00 00 " +
           hex(std::array<std::uint8_t, 3>{counter, sub, error});
  }

  std::vector<std::uint8_t> out_, in_;
  std::uint8_t counter_ = 0;
};

constexpr can::Ident Std(std::uint32_t id) {
  return {id, false};
}
constexpr can::Ident Ext(std::uint32_t id) {
  return {id, true};
}

// ---------------------------------------------------------------- the manual's examples

TEST_F(CommWindowTest, Manual5341SendData) {
  ASSERT_TRUE(setup());
  // manual §5.3.4.1: identifier 00 12, data 00..07, length 08, counter, sub 00, command 01.
  EXPECT_EQ(write(window("00 12 00 00 00 01 02 03 04 05 06 07 08 01 00 01")), idle(0x01));
  EXPECT_EQ(rec.take(), V({"012#0001020304050607"}));
  // Byte 13 echoes the counter; the same window again does not send again.
  EXPECT_EQ(poll(), idle(0x01));
  EXPECT_TRUE(rec.take().empty());
}

TEST_F(CommWindowTest, Manual5342ReceiveData) {
  ASSERT_TRUE(setup());
  // Step 2.1: enable 01 23 (command 4).
  EXPECT_EQ(write(window("01 23 00 00 00 00 00 00 00 00 00 00 00 10 00 04")), idle(0x10));
  EXPECT_TRUE(gw->comm_window().is_enabled(Std(0x123)));
  // Step 2.2: command 3 with counter + n; no data yet: EEEE.
  EXPECT_EQ(write(window("01 23 00 00 00 00 00 00 00 00 00 00 00 13 00 03")), idle(0x13));
  EXPECT_EQ(poll(), idle(0x13));
  // Step 2.3: the frame arrives asynchronously; the next read shows it with the counter of the
  // command 3 that asked for it.
  rx("123#AABBCCDDEEFF0011");
  EXPECT_EQ(poll(), "01 23 00 00 AA BB CC DD EE FF 00 11 08 13 00 00");
  EXPECT_EQ(gw->comm_window().fifo_level(), 0u);
  // Step 2.4: disable (command 5): later frames on 0x123 are not received.
  EXPECT_EQ(write(window("01 23 00 00 00 00 00 00 00 00 00 00 00 14 00 05")), idle(0x14));
  EXPECT_FALSE(gw->comm_window().is_enabled(Std(0x123)));
  rx("123#01");
  EXPECT_EQ(gw->comm_window().fifo_level(), 0u);
  EXPECT_EQ(write(window("01 23 00 00 00 00 00 00 00 00 00 00 00 15 00 03")), idle(0x15));
  EXPECT_TRUE(rec.take().empty());  // none of these commands transmits
}

TEST_F(CommWindowTest, TwentyNineBitIdentifierAsTheDocsWorkedExample) {
  // docs/communication-window.md "A 29-bit identifier, worked example": 0x18FF1234 is written
  // 12 34 38 FF (bits 15..8, 7..0, 0x20 | bits 28..24, bits 23..16).
  ASSERT_TRUE(setup());
  EXPECT_EQ(write(window("12 34 38 FF AA BB 00 00 00 00 00 00 02 05 00 01")), idle(0x05));
  EXPECT_EQ(rec.take(), V({"18FF1234#AABB"}));
  EXPECT_EQ(write(window("12 34 38 FF 00 00 00 00 00 00 00 00 00 06 00 04")), idle(0x06));
  EXPECT_TRUE(gw->comm_window().is_enabled(Ext(0x18FF1234)));
  rx("18FF1234#0102");
  EXPECT_EQ(write(window("00 00 00 00 00 00 00 00 00 00 00 00 00 07 00 03")),
            "12 34 38 FF 01 02 00 00 00 00 00 00 02 07 00 00");
  // The misreadings of the table: the identifier as a Motorola DWORD, in the comment bytes' form,
  // without the flag - error 2, nothing sent.
  EXPECT_EQ(write(window("18 FF 12 34 AA BB 00 00 00 00 00 00 02 08 00 01")), idle(0x08, 0, 2));
  EXPECT_EQ(write(window("38 FF 12 34 AA BB 00 00 00 00 00 00 02 09 00 01")), idle(0x09, 0, 2));
  EXPECT_EQ(write(window("12 34 18 FF AA BB 00 00 00 00 00 00 02 0A 00 01")), idle(0x0A, 0, 2));
  EXPECT_TRUE(rec.take().empty());
  // Silent ones: a DWORD whose third byte has bit 5 set is another 29-bit identifier, and the
  // 29-bit 0x123 without the flag is the 11-bit 0x123.
  EXPECT_EQ(write(window("18 FF 20 34 AA BB 00 00 00 00 00 00 02 0B 00 01")), idle(0x0B));
  EXPECT_EQ(write(window("01 23 00 00 AA BB 00 00 00 00 00 00 02 0C 00 01")), idle(0x0C));
  EXPECT_EQ(write(window("01 23 20 00 AA BB 00 00 00 00 00 00 02 0D 00 01")), idle(0x0D));
  EXPECT_EQ(rec.take(), V({"003418FF#AABB", "123#AABB", "00000123#AABB"}));
}

TEST_F(CommWindowTest, Manual82Fb4Sequence) {
  // manual §8.2, FB 4 networks 5-6: start frame through the window, SYNC time 0x0200, then
  // reception of the first PDO of motors 1, 10, 3, 4, 7, 8. Command 20 needs a CANopen master.
  UserPrm p = cw_prm();
  p.canopen_master = true;
  p.sync_ms = 0;
  ASSERT_TRUE(setup(p));
  EXPECT_EQ(command(kCwNop), idle(1));  // M401: CAN-ID 0, command 0
  // M401/M402: CAN-ID 0, MW4 = W#16#100 (data 01 00), length 2, command 1.
  EXPECT_EQ(command(kCwSend, Std(0), {0x01, 0x00}, 2), idle(2));
  EXPECT_EQ(rec.take(), V({"000#0100"}));
  // M402/M403: MW4 = W#16#200 = 512 ms, command 20.
  const Time t20 = now;
  EXPECT_EQ(command(kCwSyncTime, Std(0), {0x02, 0x00}, 0), idle(3));
  EXPECT_EQ(gw->status().sync_ms, 512);
  // M403..M408: command 4 for 0x181, 0x18A, 0x183, 0x184, 0x187, 0x188.
  for (std::uint32_t id : {0x181u, 0x18Au, 0x183u, 0x184u, 0x187u, 0x188u}) {
    const std::string read = command(kCwEnable, Std(id));
    EXPECT_EQ(read, idle(counter_)) << std::hex << id;
  }
  EXPECT_EQ(gw->comm_window().enabled(),
            (std::vector<can::Ident>{Std(0x181), Std(0x183), Std(0x184), Std(0x187), Std(0x188),
                                     Std(0x18A)}));
  run_until(t20 + milliseconds(1100));
  ASSERT_EQ(rec.sent.size(), 2u);
  EXPECT_EQ(rec.sent[0].time, t20 + milliseconds(512));
  EXPECT_EQ(rec.sent[1].time, t20 + milliseconds(1024));
  EXPECT_EQ(rec.take(), V({"080#", "080#"}));
  // The motors' PDOs land in the FIFO in arrival order; 0x185 is not enabled.
  rx("18A#0A");
  rx("185#05");
  rx("181#01");
  EXPECT_EQ(gw->comm_window().fifo_level(), 2u);
  EXPECT_EQ(command(kCwRead), "01 8A 00 00 0A 00 00 00 00 00 00 00 01 0A 00 00");
  EXPECT_EQ(command(kCwRead), "01 81 00 00 01 00 00 00 00 00 00 00 01 0B 00 00");
}

// ---------------------------------------------------------------- loop counter, echo, errors

TEST_F(CommWindowTest, IdleWindowBeforeAnyCommand) {
  ASSERT_TRUE(setup());
  EXPECT_EQ(poll(), idle(0));
  // docs/communication-window.md: the counter starts at 0, so a window with counter 0 does not
  // execute.
  EXPECT_EQ(write(window("00 12 00 00 11 00 00 00 00 00 00 00 01 00 00 01")), idle(0));
  EXPECT_TRUE(rec.take().empty());
}

TEST_F(CommWindowTest, RepeatedCounterDoesNotReExecute) {
  ASSERT_TRUE(setup());
  EXPECT_EQ(write(window("00 12 00 00 11 00 00 00 00 00 00 00 01 07 00 01")), idle(7));
  EXPECT_EQ(rec.take(), V({"012#11"}));
  for (int i = 0; i < 3; ++i) poll();
  // Another command with the same counter is not executed either: the counter is the trigger.
  EXPECT_EQ(write(window("00 13 00 00 22 00 00 00 00 00 00 00 01 07 00 01")), idle(7));
  EXPECT_TRUE(rec.take().empty());
  EXPECT_EQ(write(window("00 13 00 00 22 00 00 00 00 00 00 00 01 08 00 01")), idle(8));
  EXPECT_EQ(rec.take(), V({"013#22"}));
  // Any change counts, including the wrap 255 -> 0 and going backwards.
  EXPECT_EQ(write(window("00 14 00 00 33 00 00 00 00 00 00 00 01 FF 00 01")), idle(0xFF));
  EXPECT_EQ(write(window("00 14 00 00 33 00 00 00 00 00 00 00 01 00 00 01")), idle(0x00));
  EXPECT_EQ(write(window("00 14 00 00 33 00 00 00 00 00 00 00 01 05 00 01")), idle(0x05));
  EXPECT_EQ(rec.take(), V({"014#33", "014#33", "014#33"}));
}

TEST_F(CommWindowTest, SubCommandEchoed) {
  ASSERT_TRUE(setup());
  // manual table 5.3.2 byte 14: the sub-command is returned (it is not evaluated).
  EXPECT_EQ(command(kCwNop, {}, {}, 0, 0x5A), idle(1, 0x5A));
  EXPECT_EQ(command(kCwSend, Std(0x12), {1}, 1, 0xA5), idle(2, 0xA5));
  EXPECT_EQ(rec.take(), V({"012#01"}));
}

TEST_F(CommWindowTest, EveryErrorCode) {
  ASSERT_TRUE(setup());
  struct Case {
    const char* window;  // without the counter byte 13, which the test fills in
    int error;
    const char* why;
  };
  const Case cases[] = {
      // 1: invalid length (> 8) on the commands that send.
      {"00 12 00 00 00 00 00 00 00 00 00 00 09 __ 00 01", 1, "command 1, length 9"},
      {"00 12 00 00 00 00 00 00 00 00 00 00 FF __ 00 01", 1, "command 1, length 255"},
      {"00 12 00 00 00 00 00 00 00 00 00 00 09 __ 00 06", 1, "command 6, length 9"},
      {"00 12 00 00 00 00 00 00 00 00 00 00 09 __ 00 07", 1, "command 7, length 9"},
      // 2: invalid identifier.
      {"08 00 00 00 00 00 00 00 00 00 00 00 01 __ 00 01", 2, "11-bit 0x800"},
      {"FF FF 00 00 00 00 00 00 00 00 00 00 01 __ 00 01", 2, "11-bit 0xFFFF"},
      {"01 23 00 01 00 00 00 00 00 00 00 00 00 __ 00 04", 2, "byte 3 without the 29-bit flag"},
      {"01 23 10 00 00 00 00 00 00 00 00 00 00 __ 00 05", 2, "byte 2 without the 29-bit flag"},
      {"01 23 60 00 00 00 00 00 00 00 00 00 00 __ 00 04", 2, "29-bit flag with bit 30 set"},
      {"01 23 A0 00 00 00 00 00 00 00 00 00 00 __ 00 06", 2, "29-bit flag with bit 31 set"},
      // identifier before length (window byte order)
      {"08 00 00 00 00 00 00 00 00 00 00 00 09 __ 00 01", 2, "bad identifier and length"},
      // 3: unknown command.
      {"00 12 00 00 00 00 00 00 00 00 00 00 01 __ 00 02", 3, "command 2"},
      {"00 12 00 00 00 00 00 00 00 00 00 00 01 __ 00 0B", 3, "command 11 (reserved)"},
      {"00 12 00 00 00 00 00 00 00 00 00 00 01 __ 00 15", 3, "command 21"},
      {"00 12 00 00 00 00 00 00 00 00 00 00 01 __ 00 FF", 3, "command 255"},
      // 4: SYNC unavailable: layer-2 mode is no CANopen master.
      {"00 00 00 00 00 64 00 00 00 00 00 00 00 __ 00 14", 4, "command 20 in layer-2 mode"},
  };
  for (const Case& c : cases) {
    // Built by appending: replace() here trips GCC 12's false -Wrestrict at -O3 (bug 105329).
    const std::string window_text = c.window;
    const auto at = window_text.find("__");
    std::string text = window_text.substr(0, at);
    text += hex(std::array{++counter_});
    text += window_text.substr(at + 2);
    const std::string read = write(window(text.c_str()));
    EXPECT_EQ(read, idle(counter_, 0, static_cast<std::uint8_t>(c.error))) << c.why;
    EXPECT_TRUE(rec.take().empty()) << c.why;  // an erroneous command has no effect
  }
  EXPECT_EQ(gw->comm_window().enabled_count(), 0u);
  EXPECT_EQ(gw->status().sync_ms, 0);
  // The next good command reports 0 again.
  const std::string read = command(kCwNop);
  EXPECT_EQ(read, idle(counter_));
}

TEST_F(CommWindowTest, ErrorNotReleasedBeforeWakeUp) {
  // 5: CAN not yet released - a CANopen master during its wake-up time (docs/canopen.md).
  UserPrm p = cw_prm();
  p.canopen_master = true;
  p.wakeup_s = 5;
  ASSERT_TRUE(setup(p));
  EXPECT_EQ(error_of(command(kCwSend, Std(0x12), {1})), kCwErrNotReleased);
  EXPECT_EQ(error_of(command(kCwSendRtr, Std(0x181), {}, 8)), kCwErrNotReleased);
  EXPECT_EQ(error_of(command(kCwEnableAndRtr, Std(0x182), {}, 8)), kCwErrNotReleased);
  EXPECT_FALSE(gw->comm_window().is_enabled(Std(0x182)));  // command 7 did nothing at all
  // Receiving and the SYNC time need no release.
  EXPECT_EQ(error_of(command(kCwEnable, Std(0x183))), kCwOk);
  EXPECT_EQ(error_of(command(kCwRead)), kCwOk);
  EXPECT_EQ(error_of(command(kCwSyncTime, {}, {0x00, 0x64})), kCwOk);
  EXPECT_TRUE(rec.take().empty());
  run_until(seconds(5));
  EXPECT_EQ(error_of(command(kCwSend, Std(0x12), {1})), kCwOk);
  EXPECT_EQ(rec.take(), V({"012#01"}));
}

TEST_F(CommWindowTest, ErrorSyncUnavailableAsCanopenSlave) {
  UserPrm p = cw_prm();
  p.canopen_slave = true;
  p.module_id = 5;
  ASSERT_TRUE(setup(p));
  EXPECT_EQ(rec.take(), V({"085#"}));  // boot frame (canopen_test covers it)
  EXPECT_EQ(error_of(command(kCwSyncTime, {}, {0x00, 0x64})), kCwErrSyncUnavailable);
  // Pre-operational: nothing may be sent yet (docs/canopen.md).
  EXPECT_EQ(error_of(command(kCwSend, Std(0x12), {1})), kCwErrNotReleased);
  rx("000#0105");  // NMT start
  EXPECT_EQ(error_of(command(kCwSend, Std(0x12), {1})), kCwOk);
  EXPECT_EQ(rec.take(), V({"012#01"}));
}

// ---------------------------------------------------------------- commands

TEST_F(CommWindowTest, SendDataLengthsAndExtendedIdentifier) {
  ASSERT_TRUE(setup());
  EXPECT_EQ(error_of(command(kCwSend, Std(0x7FF), {}, 0)), kCwOk);
  // Data bytes past the length are not sent.
  EXPECT_EQ(error_of(command(kCwSend, Std(0x001), {1, 2, 3, 4, 5, 6, 7, 8}, 3)), kCwOk);
  // docs/communication-window.md: 29-bit 0x12345678 = 56 78 32 34.
  EXPECT_EQ(write(window("56 78 32 34 AA BB 00 00 00 00 00 00 02 F0 00 01")), idle(0xF0));
  EXPECT_EQ(rec.take(), V({"7FF#", "001#010203", "12345678#AABB"}));
}

TEST_F(CommWindowTest, RemoteFrameCommands) {
  ASSERT_TRUE(setup());
  // Command 6: remote frame with DLC = byte 12 (docs/communication-window.md).
  EXPECT_EQ(error_of(command(kCwSendRtr, Std(0x181), {}, 8)), kCwOk);
  EXPECT_FALSE(gw->comm_window().is_enabled(Std(0x181)));
  // Command 7 = command 4, then command 6.
  EXPECT_EQ(error_of(command(kCwEnableAndRtr, Ext(0x1ABCDEF0), {}, 2)), kCwOk);
  EXPECT_TRUE(gw->comm_window().is_enabled(Ext(0x1ABCDEF0)));
  EXPECT_EQ(error_of(command(kCwSendRtr, Std(0x182), {}, 0)), kCwOk);
  EXPECT_EQ(rec.take(), V({"181#R8", "1ABCDEF0#R2", "182#R"}));
}

TEST_F(CommWindowTest, EnableDistinguishes11And29BitIdentifiers) {
  ASSERT_TRUE(setup());
  command(kCwEnable, Ext(0x123));
  rx("123#01");  // 11-bit 0x123 is another identifier
  EXPECT_EQ(gw->comm_window().fifo_level(), 0u);
  rx("00000123#02");
  EXPECT_EQ(gw->comm_window().fifo_level(), 1u);
  // Read window of a 29-bit frame: byte 2 carries the flag (docs/communication-window.md).
  EXPECT_EQ(command(kCwRead), "01 23 20 00 02 00 00 00 00 00 00 00 01 02 00 00");
  // Enabling twice is one entry; disabling a never-enabled identifier is no error.
  command(kCwEnable, Ext(0x123));
  EXPECT_EQ(gw->comm_window().enabled_count(), 1u);
  EXPECT_EQ(error_of(command(kCwDisable, Std(0x555))), kCwOk);
  EXPECT_EQ(gw->comm_window().enabled_count(), 1u);
}

TEST_F(CommWindowTest, RemoteFramesAreNotReceived) {
  ASSERT_TRUE(setup());
  command(kCwEnable, Std(0x181));
  rx("181#R8");
  EXPECT_EQ(gw->comm_window().fifo_level(), 0u);
}

// ---------------------------------------------------------------- command 3 and the FIFO

TEST_F(CommWindowTest, ReadArmedBeforeTheFrameArrives) {
  ASSERT_TRUE(setup());
  command(kCwEnable, Std(0x181));
  EXPECT_EQ(command(kCwRead), idle(2));
  EXPECT_TRUE(gw->comm_window().read_armed());
  rx("181#11");  // straight into the window, not through the FIFO
  EXPECT_EQ(gw->comm_window().fifo_level(), 0u);
  EXPECT_FALSE(gw->comm_window().read_armed());
  rx("181#22");  // one command 3 delivers one frame: this one waits in the FIFO
  EXPECT_EQ(gw->comm_window().fifo_level(), 1u);
  EXPECT_EQ(poll(), "01 81 00 00 11 00 00 00 00 00 00 00 01 02 00 00");
  EXPECT_EQ(command(kCwRead), "01 81 00 00 22 00 00 00 00 00 00 00 01 03 00 00");
  EXPECT_EQ(gw->comm_window().fifo_level(), 0u);
}

TEST_F(CommWindowTest, ReadAfterFramesArrived) {
  ASSERT_TRUE(setup());
  command(kCwEnable, Std(0x181));
  command(kCwEnable, Std(0x282));
  rx("181#01");
  rx("282#0203");
  EXPECT_EQ(poll(), idle(2));  // nothing shows before a command 3
  EXPECT_EQ(command(kCwRead), "01 81 00 00 01 00 00 00 00 00 00 00 01 03 00 00");
  EXPECT_EQ(command(kCwRead), "02 82 00 00 02 03 00 00 00 00 00 00 02 04 00 00");
  EXPECT_EQ(command(kCwRead), idle(5));  // empty: armed again
  EXPECT_TRUE(gw->comm_window().read_armed());
}

TEST_F(CommWindowTest, OtherCommandsShowNoFrameAndCancelAnArmedRead) {
  ASSERT_TRUE(setup());
  command(kCwEnable, Std(0x181));
  rx("181#01");
  EXPECT_EQ(command(kCwRead), "01 81 00 00 01 00 00 00 00 00 00 00 01 02 00 00");
  // docs/communication-window.md: after every command other than 3 the window is EE EE 00 00.
  EXPECT_EQ(command(kCwNop), idle(3));
  EXPECT_EQ(command(kCwRead), idle(4));
  EXPECT_EQ(command(kCwNop), idle(5));  // the read armed by command 3 is replaced
  EXPECT_FALSE(gw->comm_window().read_armed());
  rx("181#02");
  EXPECT_EQ(poll(), idle(5));
  EXPECT_EQ(gw->comm_window().fifo_level(), 1u);
}

TEST_F(CommWindowTest, FifoKeepsOrderAndLosesThe256thFrame) {
  UserPrm p = cw_prm();
  p.can_diagnosis = true;
  ASSERT_TRUE(setup(p));
  command(kCwEnable, Std(0x100));
  command(kCwEnable, Ext(0x100));
  for (int i = 0; i < 256; ++i) {
    can::Frame f = F(i % 2 ? "00000100#00" : "100#00");
    f.data[0] = static_cast<std::uint8_t>(i);
    gw->on_can_frame(f, now);
  }
  const auto& cw = gw->comm_window();
  EXPECT_EQ(cw.fifo_level(), kCwFifoCapacity);
  EXPECT_EQ(cw.fifo_high_water(), 255u);
  EXPECT_EQ(cw.msg_lost(), 1u);
  EXPECT_EQ(gw->status().msg_lost, 1u);
  // manual table 3.4.5: MSG_LOST in diagnosis byte 10 (bus state OK in byte 8).
  const auto d = diag();
  EXPECT_EQ(hex(std::span(d).subspan(8)), "00 00 01");
  for (int i = 0; i < 255; ++i) {
    const std::string read = command(kCwRead);
    const std::string id = i % 2 ? "01 00 20 00" : "01 00 00 00";
    ASSERT_EQ(read.substr(0, 14), id + " " + hex(std::array{static_cast<std::uint8_t>(i)}))
        << "frame " << i;
  }
  const std::string last = command(kCwRead);
  EXPECT_EQ(last, idle(counter_));  // frame 255 was the one lost
  EXPECT_EQ(cw.fifo_level(), 0u);
  EXPECT_EQ(cw.fifo_high_water(), 255u);
}

TEST_F(CommWindowTest, MsgLostSaturatesInDiagnosis) {
  UserPrm p = cw_prm();
  p.can_diagnosis = true;
  ASSERT_TRUE(setup(p));
  command(kCwEnable, Std(0x100));
  for (int i = 0; i < 255 + 300; ++i) rx("100#01");
  EXPECT_EQ(gw->comm_window().msg_lost(), 300u);
  EXPECT_EQ(diag()[10], 255);  // docs/dp-slave.md "Diagnosis": saturates at 255
  // Reading makes room again: the next frame is stored, not lost.
  command(kCwRead);
  rx("100#02");
  EXPECT_EQ(gw->comm_window().msg_lost(), 300u);
  EXPECT_EQ(gw->comm_window().fifo_level(), 255u);
}

TEST_F(CommWindowTest, PowerCycleStartsEveryCounterAtZero) {
  // docs/faults.md "Power cycle and re-parameterization": a restarted gateway starts every counter
  // at 0 - frames, Data_Exchanges, IRQ_LOST (diagnosis byte 9), MSG_LOST (byte 10), the FIFO.
  UserPrm p = cw_prm();
  p.can_diagnosis = true;
  ASSERT_TRUE(setup(p));
  command(kCwEnable, Std(0x100));
  for (int i = 0; i < 256; ++i) rx("100#01");  // the 256th is lost at the full FIFO
  command(kCwSend, Std(0x12), {1});
  gw->set_controller_status(can::BusState::Ok, 7);  // the transport lost 7 frames
  GatewayStatus st = gw->status();
  ASSERT_EQ(st.irq_lost, 7u);
  ASSERT_EQ(st.msg_lost, 1u);
  const auto before = diag();
  ASSERT_EQ(hex(std::span(before).subspan(8)), "00 07 01");

  gw->power_cycle(now);
  st = gw->status();
  EXPECT_EQ(st.rx_frames, 0u);
  EXPECT_EQ(st.tx_frames, 0u);
  EXPECT_EQ(st.irq_lost, 0u);
  EXPECT_EQ(st.msg_lost, 0u);
  EXPECT_EQ(st.fifo_level, 0u);
  EXPECT_EQ(st.fifo_high_water, 0u);
  EXPECT_EQ(st.data_exchanges, 0u);
  // The transport's own count runs on: only what it loses after the restart counts.
  gw->set_controller_status(can::BusState::Ok, 7);
  EXPECT_EQ(gw->status().irq_lost, 0u);
  gw->set_controller_status(can::BusState::Ok, 9);
  EXPECT_EQ(gw->status().irq_lost, 2u);
  ASSERT_TRUE(setup(p));
  const auto d = diag();
  EXPECT_EQ(hex(std::span(d).subspan(8)), "00 02 00");
}

TEST_F(CommWindowTest, FramesStoredWhileTheDpMasterIsAway) {
  // Reception is asynchronous to the PLC (manual §5.3.3 command 3): frames are stored between
  // Data_Exchanges, also after a watchdog drop; the same configuration keeps them
  // (docs/slots.md "Data exchange in normal mode").
  ASSERT_TRUE(configure(cw_prm(), kCwCfg, 50));
  out_.assign(16, 0);
  command(kCwEnable, Std(0x181));
  run_for(milliseconds(100));
  ASSERT_EQ(gw->dp().state(), dp::SlaveState::WaitPrm);
  rx("181#01");
  ASSERT_TRUE(configure(cw_prm(), kCwCfg, 50));
  EXPECT_EQ(command(kCwRead), "01 81 00 00 01 00 00 00 00 00 00 00 01 02 00 00");
}

// ---------------------------------------------------------------- CW and slots

TEST_F(CommWindowTest, EnabledIdentifiersTakePrecedenceOverInputSlots) {
  const auto cfg = cfg_of({in_slot(2, {0x01, 0x81, 0x00}), out_slot(1, {0x02, 0x01, 0x00}),
                           in_slot(16, {0xFF, 0xEF, 0x00}), out_slot(16, {0xFF, 0xEF, 0x00})});
  ASSERT_TRUE(setup(cw_prm(), cfg));
  EXPECT_EQ(slot(gw->slot_config()->cw_in).offset, 2u);
  EXPECT_EQ(slot(gw->slot_config()->cw_out).offset, 1u);
  rx("181#1111");
  EXPECT_EQ(slot_bytes(), "11 11");
  // docs/slots.md "Data exchange in normal mode" / manual §5.2.1: while enabled in the CW, 0x181 no
  // longer updates the slot.
  command(kCwEnable, Std(0x181));
  rx("181#2222");
  EXPECT_EQ(slot_bytes(), "11 11");
  EXPECT_EQ(gw->comm_window().fifo_level(), 1u);
  command(kCwDisable, Std(0x181));
  rx("181#3333");
  EXPECT_EQ(slot_bytes(), "33 33");
  EXPECT_EQ(gw->comm_window().fifo_level(), 1u);  // the frame received while enabled stays
}

TEST_F(CommWindowTest, SlotAndWindowFramesOfOneExchange) {
  const auto cfg = cfg_of({out_slot(1, {0x02, 0x01, 0x00}), in_slot(16, {0xFF, 0xEF, 0x00}),
                           out_slot(16, {0xFF, 0xEF, 0x00})});
  ASSERT_TRUE(setup(cw_prm(), cfg));
  out_[0] = 0x55;
  command(kCwSend, Std(0x12), {0x66});
  EXPECT_EQ(rec.take(), V({"201#55", "012#66"}));  // slots first, then the window's command
}

TEST_F(CommWindowTest, NewConfigurationResetsTheWindow) {
  ASSERT_TRUE(setup());
  command(kCwEnable, Std(0x181));
  rx("181#01");
  // Re-parameterization with the same configuration keeps the window
  // (docs/slots.md "Data exchange in normal mode") ...
  ASSERT_TRUE(configure(cw_prm(), kCwCfg));
  EXPECT_EQ(gw->comm_window().fifo_level(), 1u);
  EXPECT_EQ(poll(), idle(1));
  // ... a different one starts from the power-on state.
  const auto other = cfg_of({out_slot(16, {0xFF, 0xEF, 0x00}), in_slot(16, {0xFF, 0xEF, 0x00})});
  ASSERT_TRUE(configure(cw_prm(), other));
  EXPECT_EQ(gw->comm_window().enabled_count(), 0u);
  EXPECT_EQ(gw->comm_window().fifo_level(), 0u);
  std::fill(out_.begin(), out_.end(), 0);
  EXPECT_EQ(poll(), idle(0));
}

// ---------------------------------------------------------------- the pure wire formats

TEST(CwWire, IdentifierEncoding) {
  // docs/communication-window.md.
  std::array<std::uint8_t, 4> b{};
  cw_encode_ident(Std(0x123), b);
  EXPECT_EQ(hex(b), "01 23 00 00");
  cw_encode_ident(Ext(0x12345678), b);
  EXPECT_EQ(hex(b), "56 78 32 34");
  cw_encode_ident(Ext(0x1FFFFFFF), b);
  EXPECT_EQ(hex(b), "FF FF 3F FF");
  EXPECT_EQ(cw_decode_ident(b), Ext(0x1FFFFFFF));
  cw_encode_ident(Ext(0), b);
  EXPECT_EQ(hex(b), "00 00 20 00");
  EXPECT_EQ(cw_decode_ident(b), Ext(0));
  const std::array<std::uint8_t, 4> bad_std{0x08, 0x00, 0x00, 0x00};
  EXPECT_FALSE(cw_decode_ident(bad_std));
  const std::array<std::uint8_t, 4> max_std{0x07, 0xFF, 0x00, 0x00};
  EXPECT_EQ(cw_decode_ident(max_std), Std(0x7FF));
}

TEST(CwWire, RequestRoundTrip) {
  const auto w = window("56 78 32 34 01 02 03 04 05 06 07 08 08 2A 5A 07");
  const CwRequest r = decode_cw_request(w);
  EXPECT_EQ(r.identifier(), Ext(0x12345678));
  EXPECT_EQ(r.length, 8);
  EXPECT_EQ(r.counter, 0x2A);
  EXPECT_EQ(r.sub_command, 0x5A);
  EXPECT_EQ(r.command, kCwEnableAndRtr);
  EXPECT_EQ(r.sync_ms(), 0x0102);
  EXPECT_EQ(encode_cw_request(r), w);
}

TEST(CwWire, ReplyEncodingAndValidation) {
  CwReply idle_reply{std::nullopt, 7, 1, kCwErrLength};
  EXPECT_EQ(hex(encode_cw_reply(idle_reply)), "EE EE 00 00 00 00 00 00 00 00 00 00 00 07 01 01");
  EXPECT_EQ(decode_cw_reply(encode_cw_reply(idle_reply)), idle_reply);
  // A 29-bit identifier ending in EEEE is a frame: byte 2 carries the 29-bit flag.
  CwReply ext{F("0000EEEE#01"), 1, 0, 0};
  EXPECT_EQ(hex(encode_cw_reply(ext)), "EE EE 20 00 01 00 00 00 00 00 00 00 01 01 00 00");
  EXPECT_EQ(decode_cw_reply(encode_cw_reply(ext)), ext);
  // Bytes no gateway writes.
  for (const char* bad : {"EE EE 00 00 01 00 00 00 00 00 00 00 00 00 00 00",   // data without frame
                          "01 23 00 00 00 00 00 00 00 00 00 00 09 00 00 00",   // length 9
                          "01 23 00 00 00 00 11 00 00 00 00 00 01 00 00 00",   // data past length
                          "08 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00"})  // 11-bit 0x800
    EXPECT_FALSE(decode_cw_reply(window(bad))) << bad;
}

TEST(CwWire, FifoRing) {
  CwFifo fifo;
  for (int round = 0; round < 3; ++round) {  // wraps around the ring
    for (int i = 0; i < 200; ++i) {
      can::Frame f = F("100#00");
      f.data[0] = static_cast<std::uint8_t>(i);
      ASSERT_TRUE(fifo.push(f));
    }
    for (int i = 0; i < 200; ++i) ASSERT_EQ(fifo.pop()->data[0], static_cast<std::uint8_t>(i));
    EXPECT_TRUE(fifo.empty());
  }
  for (std::size_t i = 0; i < CwFifo::capacity(); ++i) ASSERT_TRUE(fifo.push(F("100#")));
  EXPECT_TRUE(fifo.full());
  EXPECT_FALSE(fifo.push(F("100#")));
  EXPECT_EQ(fifo.size(), 255u);
  EXPECT_FALSE(CwFifo{}.pop());
}

}  // namespace
}  // namespace candp2::gw::test

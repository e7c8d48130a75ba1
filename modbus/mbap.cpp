#include "modbus/mbap.hpp"

#include <algorithm>

namespace candp2::modbus {

std::string_view to_string(Exception e) {
  switch (e) {
    case Exception::IllegalFunction:
      return "illegal function";
    case Exception::IllegalDataAddress:
      return "illegal data address";
    case Exception::IllegalDataValue:
      return "illegal data value";
    case Exception::ServerDeviceFailure:
      return "server device failure";
    case Exception::GatewayTargetFailed:
      return "gateway target device failed to respond";
  }
  return "?";
}

std::string_view to_string(Table t) {
  switch (t) {
    case Table::Coils:
      return "coils";
    case Table::DiscreteInputs:
      return "discrete inputs";
    case Table::HoldingRegisters:
      return "holding registers";
    case Table::InputRegisters:
      return "input registers";
  }
  return "?";
}

// ------------------------------------------------------------------------------------- framing

void MbapFramer::append(std::span<const std::uint8_t> bytes) {
  if (start_ > 0 && start_ == buffer_.size()) {
    buffer_.clear();
    start_ = 0;
  } else if (start_ > 4096) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start_));
    start_ = 0;
  }
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
}

MbapFramer::Next MbapFramer::next() {
  Next n;
  const std::size_t avail = buffer_.size() - start_;
  if (avail < kMbapLen) return n;
  const std::uint8_t* h = buffer_.data() + start_;
  const unsigned protocol = (h[2] << 8) | h[3];
  const unsigned length = (h[4] << 8) | h[5];  // unit id + PDU
  if (protocol != 0) {
    n.status = Status::Garbage;
    n.why = "MBAP protocol identifier " + std::to_string(protocol) + " (Modbus is 0)";
    return n;
  }
  // TCP guide §3.1.3: the length counts the unit id and the PDU (function code + data, 1..253).
  if (length < 2 || length > 1 + kMaxPduLen) {
    n.status = Status::Garbage;
    n.why =
        "MBAP length " + std::to_string(length) + " outside 2.." + std::to_string(1 + kMaxPduLen);
    return n;
  }
  const std::size_t total = 6 + length;
  if (avail < total) return n;
  n.status = Status::Frame;
  n.adu = std::span<const std::uint8_t>(h, total);
  start_ += total;
  return n;
}

// -------------------------------------------------------------------------------------- decode

bool Request::writes() const {
  switch (function) {
    case Function::WriteSingleCoil:
    case Function::WriteSingleRegister:
    case Function::WriteMultipleCoils:
    case Function::WriteMultipleRegisters:
    case Function::MaskWriteRegister:
    case Function::ReadWriteMultipleRegisters:
      return true;
    default:
      return false;
  }
}

namespace {

std::uint16_t be16(std::span<const std::uint8_t> p, std::size_t at) {
  return static_cast<std::uint16_t>((p[at] << 8) | p[at + 1]);
}

DecodeFailure value_error(std::string why) {
  return {Exception::IllegalDataValue, std::move(why)};
}

std::string count_text(std::uint16_t n, std::uint16_t max) {
  return "quantity " + std::to_string(n) + " outside 1.." + std::to_string(max);
}

}  // namespace

std::variant<Request, DecodeFailure> decode_request(std::span<const std::uint8_t> adu) {
  Request r;
  r.transaction = be16(adu, 0);
  r.unit = adu[6];
  const std::span<const std::uint8_t> pdu = adu.subspan(kMbapLen);  // function code + data
  const std::uint8_t fc = pdu[0];
  auto need = [&](std::size_t len) -> std::optional<DecodeFailure> {
    if (pdu.size() == len) return std::nullopt;
    return value_error("PDU of function 0x" + std::string(1, "0123456789ABCDEF"[fc >> 4]) +
                       std::string(1, "0123456789ABCDEF"[fc & 15]) + " has " +
                       std::to_string(pdu.size()) + " bytes, expected " + std::to_string(len));
  };
  switch (fc) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x04: {
      r.function = static_cast<Function>(fc);
      r.table = fc == 0x01   ? Table::Coils
                : fc == 0x02 ? Table::DiscreteInputs
                : fc == 0x03 ? Table::HoldingRegisters
                             : Table::InputRegisters;
      if (auto f = need(5)) return *f;
      r.address = be16(pdu, 1);
      r.count = be16(pdu, 3);
      const std::uint16_t max = fc <= 0x02 ? kMaxReadBits : kMaxReadRegisters;
      if (r.count < 1 || r.count > max) return value_error(count_text(r.count, max));
      return r;
    }
    case 0x05:
    case 0x06: {
      r.function = static_cast<Function>(fc);
      r.table = fc == 0x05 ? Table::Coils : Table::HoldingRegisters;
      if (auto f = need(5)) return *f;
      r.address = r.write_address = be16(pdu, 1);
      r.count = r.write_count = 1;
      r.values = pdu.subspan(3, 2);
      // MB spec §6.5: a coil value other than FF00 or 0000 is illegal.
      if (fc == 0x05 && be16(pdu, 3) != kCoilOn && be16(pdu, 3) != kCoilOff)
        return value_error("coil value must be FF00 or 0000");
      return r;
    }
    case 0x0F:
    case 0x10: {
      r.function = static_cast<Function>(fc);
      r.table = fc == 0x0F ? Table::Coils : Table::HoldingRegisters;
      if (pdu.size() < 6) return *need(6);
      r.address = r.write_address = be16(pdu, 1);
      r.count = r.write_count = be16(pdu, 3);
      const std::uint16_t max = fc == 0x0F ? kMaxWriteBits : kMaxWriteRegisters;
      if (r.count < 1 || r.count > max) return value_error(count_text(r.count, max));
      const std::size_t bytes = fc == 0x0F ? (r.count + 7u) / 8u : 2u * r.count;
      if (pdu[5] != bytes)
        return value_error("byte count " + std::to_string(pdu[5]) + ", expected " +
                           std::to_string(bytes));
      if (auto f = need(6 + bytes)) return *f;
      r.values = pdu.subspan(6, bytes);
      return r;
    }
    case 0x16: {
      r.function = Function::MaskWriteRegister;
      r.table = Table::HoldingRegisters;
      if (auto f = need(7)) return *f;
      r.address = r.write_address = be16(pdu, 1);
      r.count = r.write_count = 1;
      r.and_mask = be16(pdu, 3);
      r.or_mask = be16(pdu, 5);
      return r;
    }
    case 0x17: {
      r.function = Function::ReadWriteMultipleRegisters;
      r.table = Table::HoldingRegisters;
      if (pdu.size() < 10) return *need(10);
      r.address = be16(pdu, 1);
      r.count = be16(pdu, 3);
      r.write_address = be16(pdu, 5);
      r.write_count = be16(pdu, 7);
      if (r.count < 1 || r.count > kMaxReadRegisters)
        return value_error("read " + count_text(r.count, kMaxReadRegisters));
      if (r.write_count < 1 || r.write_count > kMaxReadWriteWriteRegs)
        return value_error("write " + count_text(r.write_count, kMaxReadWriteWriteRegs));
      const std::size_t bytes = 2u * r.write_count;
      if (pdu[9] != bytes)
        return value_error("byte count " + std::to_string(pdu[9]) + ", expected " +
                           std::to_string(bytes));
      if (auto f = need(10 + bytes)) return *f;
      r.values = pdu.subspan(10, bytes);
      return r;
    }
    default:
      return DecodeFailure{Exception::IllegalFunction,
                           "function code " + std::to_string(fc) + " not supported"};
  }
}

}  // namespace candp2::modbus

// What the gateway's engines may do on the CAN side. The Gateway implements it: it counts frames,
// and knows whether CAN transmission is released (docs/canopen.md).
#pragma once

#include "can/frame.hpp"

namespace candp2::gw {

class TxPort {
 public:
  virtual ~TxPort() = default;
  // Slot and page traffic may go out (released and the DP slave in Data_Exch).
  virtual bool tx_active() const = 0;
  // Puts a frame on the bus now. Callers check tx_active() where the rules require it.
  virtual void transmit(const can::Frame& frame) = 0;
};

// The 32-bit key used for identifier lookups: the 29-bit flag in bit 31.
inline std::uint32_t ident_key(const can::Ident& id) {
  return id.id | (id.extended ? 0x80000000u : 0u);
}
inline std::uint32_t ident_key(const can::Frame& f) {
  return f.id | (f.extended ? 0x80000000u : 0u);
}

}  // namespace candp2::gw

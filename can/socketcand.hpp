// The socketcand protocol (linux-can/socketcand, doc/protocol.md), raw mode, both sides.
//
// Server: exports one bus (any can::Channel the owner pumps, normally a VirtualBus endpoint) to TCP
// clients such as python-can's `socketcand` interface: greets with `< hi >`, accepts
// `< open CHANNEL >` answering `< ok >`, `< rawmode >` answering `< ok >`, then forwards every bus
// frame as `< frame ID SECONDS.USECONDS DATAHEX >` and sends every `< send ID DLC B0 B1 ... >` onto
// the bus. Unknown commands get `< error ... >`; a misbehaving client is dropped, never the daemon.
// Client: connects to a socketcand server and behaves as a can::Channel.
//
// Wire details, as socketcand itself does them (src/state_raw.c, src/state_nobus.c):
//  - identifiers are upper-case hex without 0x: 3 digits for 11-bit, 8 digits for 29-bit; in
//    `< send >` an 8-digit identifier means a 29-bit frame;
//  - `< frame >` data is upper-case, zero-padded, without spaces (`1122`; nothing for DLC 0, which
//    leaves two spaces before `>`); `< send >` data bytes are separate 1–2 digit hex words;
//  - the protocol has no remote frames: socketcand drops received RTR frames in raw mode and
//    `< send >` cannot express one. This implementation does the same (see the server and client
//    comments), so remote frames do not cross a socketcand link;
//  - error frames travel as `< error CLASS SECONDS.USECONDS >` (CLASS = can_id & CAN_ERR_MASK).
// Deliberate differences, all on input that socketcand mishandles: a `< send >` identifier with
// fewer than 8 digits but a value above 0x7FF is taken as 29-bit (python-can sends ids unpadded);
// malformed `< send >` commands are answered with `< error ... >` (socketcand ignores them
// silently); `< rawmode >` while already in raw mode answers `< ok >`.
//
// Both are driven by the caller's event loop: they expose descriptors to poll and handle readiness.
//
// Split by role: socketcand_protocol.hpp (pure framing), socketcand_server.hpp,
// socketcand_client.hpp; socketcand_net.hpp holds the socket helpers both share.
#pragma once

#include "can/socketcand_client.hpp"
#include "can/socketcand_protocol.hpp"
#include "can/socketcand_server.hpp"

// The channel contract for the transports every machine has: the in-process virtual bus and the
// socketcand client talking to our socketcand server over 127.0.0.1.
#include "channel_contract.hpp"

namespace candp2::test {
namespace {

using InProcessAndTcp = ::testing::Types<VirtualRig, SocketcandRig>;
INSTANTIATE_TYPED_TEST_SUITE_P(Transports, ChannelContract, InProcessAndTcp, RigNames);

}  // namespace
}  // namespace candp2::test

# Guest script for tools/qemu/run-guest (busybox ash): the SocketCAN tests on a real kernel.
# vcan0 is up (run-guest sets it up); vcan9 exists but stays down for the "is down" error path.
. /etc/candp2/guest-lib.sh
ip link add dev vcan9 type vcan || fail "cannot create vcan9"
status=0
transport_socketcan_tests --gtest_brief=1 || status=1
CANDP2_TEST_CAN_DOWN_IFACE=vcan9 transport_tests --gtest_brief=1 --gtest_filter='SocketCan*' ||
  status=1
exit $status

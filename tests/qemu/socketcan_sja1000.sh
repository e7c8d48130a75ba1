#!/bin/sh
# Guest script for run-guest --sja1000: the emulated CAN bus works. Two SJA1000 controllers (QEMU
# kvaser_pci, driven by the kernel's sja1000/kvaser_pci modules) on one QEMU can-bus: can0 and can1
# get a bit rate through iproute2's ip and exchange frames in both directions.
set -u
. /etc/candp2/guest-lib.sh
IP=/usr/local/bin/iproute2-ip

for dev in can0 can1; do
    [ "$(cat /sys/class/net/$dev/type)" = 280 ] || fail "$dev is not ARPHRD_CAN (280)"
    $IP link set $dev type can bitrate 500000 || fail "$dev: bit rate"
    $IP link set $dev up || fail "$dev: up"
done
$IP -details link show can0 | tee /tmp/can0.txt
grep -q 'sja1000: tseg1' /tmp/can0.txt || fail "can0 is not driven by sja1000"
grep -q 'bitrate 500000 ' /tmp/can0.txt || fail "can0 bit rate not 500000"
grep -q 'state ERROR-ACTIVE' /tmp/can0.txt || fail "can0 not error-active"

# Other sockets on the sending interface get a local echo of each frame; candump on can1 sees only
# what crossed the emulated bus.
timeout 20 candump -L -n 2 can1 >/tmp/can1.log &
d1=$!
timeout 20 candump -L -n 1 can0,321:7FF >/tmp/can0.log & # not can0's own echo
d0=$!
wait_can_receiver can1
wait_can_receiver can0
cansend can0 123#1122 || fail "cansend can0"
cansend can0 12345678#AABB || fail "cansend can0 EFF"
wait $d1 || fail "can1 did not receive the frames of can0"
cansend can1 321#33 || fail "cansend can1"
wait $d0 || fail "can0 did not receive the frame of can1"
sed -e 's/^([0-9]*\.[0-9]*) //' /tmp/can1.log /tmp/can0.log >/tmp/got.txt
printf '%s\n' 'can1 123#1122' 'can1 12345678#AABB' 'can0 321#33' >/tmp/want.txt
diff -u /tmp/want.txt /tmp/got.txt || fail "frames differ (- expected, + received)"
echo "PASS: two emulated SJA1000 on one QEMU CAN bus exchange frames at 500 kbit/s"

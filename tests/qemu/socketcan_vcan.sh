#!/bin/sh
# Guest script (runs inside the QEMU guest of tools/qemu/run-guest, busybox ash): proves that real
# SocketCAN works on vcan0 with the independent can-utils peers. candump receives what cansend
# writes through the kernel's CAN_RAW sockets; the candump log must hold exactly the three frames.
set -u
# shellcheck source=SCRIPTDIR/../../tools/qemu/guest-lib.sh
. /etc/candp2/guest-lib.sh

[ -d /sys/class/net/vcan0 ] || fail "vcan0 missing"
[ "$(cat /sys/class/net/vcan0/type)" = 280 ] || fail "vcan0 is not ARPHRD_CAN (280)"

# candump stops after the 3 frames (-n 3); `timeout` bounds it if a frame never arrives.
timeout 20 candump -L -n 3 vcan0 >/tmp/candump.log 2>/tmp/candump.err &
dump_pid=$!
# Sending before candump's socket is bound would lose frames: wait for its receive filter.
wait_until 10 can_receiver_on vcan0 || fail "candump did not bind to vcan0: $(cat /tmp/candump.err)"

cansend vcan0 123#1122 || fail "cansend 123#1122"           # 11-bit data frame
cansend vcan0 12345678#AABB || fail "cansend 12345678#AABB" # 29-bit (EFF) data frame
cansend vcan0 123#R4 || fail "cansend 123#R4"               # remote frame, DLC 4

wait "$dump_pid"
rc=$?
[ "$rc" -eq 0 ] ||
    fail "candump exited with $rc (143: timeout, frames missing): $(cat /tmp/candump.err)"

echo "candump log:"
cat /tmp/candump.log
# candump -L lines are "(seconds.micros) vcan0 123#1122": check the timestamp, then drop it.
[ "$(grep -c '^([0-9]*\.[0-9]*) vcan0 ' /tmp/candump.log)" -eq 3 ] ||
    fail "malformed candump -L lines"
sed -e 's/^([0-9]*\.[0-9]*) //' /tmp/candump.log >/tmp/got.txt
printf '%s\n' 'vcan0 123#1122' 'vcan0 12345678#AABB' 'vcan0 123#R4' >/tmp/want.txt
diff -u /tmp/want.txt /tmp/got.txt ||
    fail "candump output differs from the frames sent (diff above: - expected, + received)"
echo "PASS: SocketCAN on vcan0: candump received exactly the 3 frames cansend sent"

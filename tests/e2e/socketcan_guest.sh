# candp2d on real SocketCAN (vcan0) inside the QEMU guest of tools/qemu/run-guest: the manual
# §5.1.4 round trip with mbpoll, candump and cansend, and the clear error for a missing interface.
# Run by ctest (label qemu) as:
#   run-guest --bin build/bin/candp2d --bin /usr/bin/mbpoll \
#       --file config/socketcan.json:/etc/candp2/candp2d.json --script tests/e2e/socketcan_guest.sh
. /etc/candp2/guest-lib.sh

# A missing interface: exit status 1 and a message naming it.
sed 's/"interface": "vcan0"/"interface": "vcan9"/' /etc/candp2/candp2d.json >/tmp/missing.json
candp2d --config /tmp/missing.json >/tmp/missing.log 2>&1
rc=$?
[ "$rc" = 1 ] || fail "missing interface: exit status $rc, expected 1"
grep -q 'cannot open SocketCAN interface vcan9' /tmp/missing.log || fail "no clear error: $(cat /tmp/missing.log)"

candp2d --config /etc/candp2/candp2d.json >/out/candp2d.log 2>&1 &
wait_tcp_listen 1502
timeout 20 candump -L -n 1 vcan0,309:7FF >/tmp/dump.log &
dump=$!
wait_can_receiver vcan0
# Input register 8192 = 2: the master has the gateway in Data_Exch.
wait_until 10 sh -c 'mbpoll -m tcp -p 1502 -a 5 -0 -r 8192 -t 3 -1 127.0.0.1 | grep -q "\[8192\]:[[:space:]]*2$"' \
    || fail "gateway not in Data_Exch"
# Q 172..177 = holding registers 86..88; form B8: a b c d e f -> b a f e d c.
mbpoll -m tcp -p 1502 -a 5 -0 -r 86 -t 4:hex -1 127.0.0.1 0x0A0B 0x0C0D 0x0E0F >/dev/null \
    || fail "mbpoll write"
wait $dump || fail "no frame 0x309 on vcan0"
grep -q ' vcan0 309#0B0A0F0E0D0C$' /tmp/dump.log || fail "wrong frame: $(cat /tmp/dump.log)"
cansend vcan0 289#0B0A0F0E0D0C
wait_until 5 sh -c 'mbpoll -m tcp -p 1502 -a 5 -0 -r 86 -c 3 -t 3:hex -1 127.0.0.1 | grep -q "\[88\]:[[:space:]]*0x0E0F"' \
    || fail "input image not updated"
mbpoll -m tcp -p 1502 -a 5 -0 -r 86 -c 3 -t 3:hex -1 127.0.0.1 | grep -q "\[86\]:[[:space:]]*0x0A0B" \
    || fail "input register 86"
echo "candp2d on SocketCAN: OK"

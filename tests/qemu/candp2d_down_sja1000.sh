#!/bin/sh
# Guest script for run-guest --sja1000 (tests/qemu/CMakeLists.txt): candp2d on can0 as an interface
# is after boot (docs/transports.md "Down interfaces"), can-utils on can1 at 500 kbit/s as the
# peer. The gateway's Set_Prm asks for 500 kbit/s (manual §5.1.2 "CAN-Bitrate", table 5.1.1:
# byte 8 = 2); /etc/candp2/candp2d.json is config/socketcan.json (the manual §5.1.4 slots).
#   apply-down          "bitrate": "apply", can0 down at 125 kbit/s: candp2d sets 500 kbit/s and
#                       restart-ms 100 and brings it up; later taken down by hand, the gateway
#                       shows bus-off, the log gives the command, and it recovers when that runs
#   apply-no-bittiming  "bitrate": "apply", can0 as booted (down, never given a bit rate): the same
#   check-down          "bitrate": "check", can0 down at 125 kbit/s: candp2d starts and shows
#                       bus-off (diagnosis byte 8, LED C, status block); the command from its log
#                       is run here; then frames flow
# Every case exchanges the manual §5.1.4 frames with can1 once can0 is up.
set -u
. /etc/candp2/guest-lib.sh
IP=/usr/local/bin/iproute2-ip # iproute2 (run-guest --sja1000); busybox ip cannot set bit timing
CASE=${1:?case: apply-down, apply-no-bittiming or check-down}

# reg ADDRESS: one input register of unit 5 (the gateway's status block, docs/modbus.md), 0xNNNN.
reg() {
    mbpoll -m tcp -p 1502 -a 5 -0 -r "$1" -t 3:hex -1 127.0.0.1 2>/dev/null |
        sed -n "s/^\[$1\]:[[:space:]]*//p"
}
reg_is() { [ "$(reg "$1")" = "$2" ]; }
log_has() { grep -qF "$1" /out/candp2d.log; }
# bus STATE: 8201 diagnosis byte 8 (CAN-Diagnosis on), 8225 LED C, 8205 bus_state
# (docs/transports.md "Controller states"): ok 0x00/1/0, bus-off 0xC0/'O'/3.
bus_is() {
    case $1 in
    ok) reg_is 8201 0x0000 && reg_is 8225 0x0001 && reg_is 8205 0x0000 ;;
    bus-off) reg_is 8201 0x00C0 && reg_is 8225 0x004F && reg_is 8205 0x0003 ;;
    esac
}
bus_text() { echo "diag8 $(reg 8201) led_c $(reg 8225) bus_state $(reg 8205)"; }
# run_logged_command: the `ip link set can0 ...` command of the log's "is down" line, run as is
# (with iproute2's ip): proves that the line says exactly what to run.
run_logged_command() {
    cmd=$(grep -F 'interface can0 is down' /out/candp2d.log | tail -1 |
        sed -n 's/.*`\(ip link set can0 [^`]*\)`.*/\1/p')
    [ -n "$cmd" ] || fail "no ip link command in the log: $(cat /out/candp2d.log)"
    echo "running the logged command: $cmd"
    eval "$(echo "$cmd" | sed "s#ip link#$IP link#g")" || fail "the logged command failed: $cmd"
}
# round_trip: manual §5.1.4, Q 172..177 = holding registers 86..88 go out as 0x309 with form B8
# (a b c d e f -> b a f e d c); 0x289 from can1 comes back in input registers 86..88.
round_trip() {
    timeout 20 candump -L -n 1 "can1,309:7FF" >/tmp/dump.log &
    dump=$!
    wait_can_receiver can1
    mbpoll -m tcp -p 1502 -a 5 -0 -r 86 -t 4:hex -1 127.0.0.1 $1 >/dev/null || fail "mbpoll write"
    wait $dump || fail "no frame 0x309 on can1"
    grep -q " can1 309#$2\$" /tmp/dump.log || fail "wrong frame: $(cat /tmp/dump.log)"
    cansend can1 "289#$2"
    wait_until 5 sh -c "mbpoll -m tcp -p 1502 -a 5 -0 -r 86 -c 3 -t 3:hex -1 127.0.0.1 |
        grep -q '\[88\]:[[:space:]]*$3'" || fail "input image not updated from 289#$2"
}

$IP link set can1 type can bitrate 500000 && $IP link set can1 up || fail "can1 at 500k"
case $CASE in
apply-down | check-down)
    $IP link set can0 type can bitrate 125000 || fail "can0 at 125k"
    ;;
apply-no-bittiming)
    $IP -details link show can0 | grep -q ' bitrate ' &&
        fail "can0 has a bit timing at boot: $($IP -details link show can0)"
    ;;
*) fail "unknown case $CASE" ;;
esac
# IFF_UP is the flag list's UP (iproute2's "state" is the operational state, DOWN without carrier).
is_up() { $IP link show "$1" | grep -q '[<,]UP[,>]'; }
is_up can0 && fail "can0 not down at start"
mode=${CASE%%-*}
opts="\"bitrate\": \"$mode\""
[ "$mode" = apply ] && opts="$opts, \"restart_ms\": 100"
sed -e "s/\"interface\": \"vcan0\"/\"interface\": \"can0\", $opts/" \
    -e 's/"can_bitrate": "125k"/"can_bitrate": "500k"/' \
    /etc/candp2/candp2d.json >/tmp/candp2d.json

candp2d --config /tmp/candp2d.json >/out/candp2d.log 2>&1 &
wait_tcp_listen 1502
wait_until 10 reg_is 8192 0x0002 || fail "gateway not in Data_Exch: $(cat /out/candp2d.log)"
log_has 'opened, but the interface is down' || fail "no down line at opening"

if [ "$mode" = apply ]; then
    was="was 125 kbit/s, down"
    [ "$CASE" = apply-no-bittiming ] && was="was no bit timing, down"
    wait_until 10 log_has "bit rate set to 500 kbit/s from the Set_Prm of gateway gw5 ($was), restart-ms 100; interface up" ||
        fail "apply: no log line: $(cat /out/candp2d.log)"
    $IP -details link show can0 >/out/can0.txt
    grep -q '[<,]UP[,>]' /out/can0.txt && grep -q 'bitrate 500000 ' /out/can0.txt &&
        grep -q 'restart-ms 100' /out/can0.txt || fail "can0 not up at 500k: $(cat /out/can0.txt)"
    wait_until 5 bus_is ok || fail "apply: bus not ok: $(bus_text)"
    log_has 'interface is up again; controller error-active' || fail "channel did not see can0 up"
else
    # check: bus-off while down, the mismatch 500k vs 125k in the status block, and the command.
    wait_until 5 bus_is bus-off || fail "check: not bus-off while can0 is down: $(bus_text)"
    [ "$(reg 8229)/$(reg 8230)/$(reg 8231)/$(reg 8232)/$(reg 8233)/$(reg 8234)" = \
        0x0001/0x0007/0xA120/0x0001/0xE848/0x0001 ] ||
        fail "check: status $(reg 8229)/$(reg 8230)/$(reg 8231)/$(reg 8232)/$(reg 8233)/$(reg 8234)"
    log_has 'interface can0 is down: the gateways on it report bus-off until it is up at 500 kbit/s (Set_Prm of gateway gw5): `ip link set can0 type can bitrate 500000 && ip link set can0 up`' ||
        fail "check: no command in the log: $(cat /out/candp2d.log)"
    is_up can0 && fail "check brought can0 up"
    run_logged_command
    wait_until 5 bus_is ok || fail "check: bus not ok after can0 up: $(bus_text)"
    # The supervisor reads the interface again within 5 s: rate and mismatch flag follow.
    wait_until 10 reg_is 8234 0x0000 || fail "check: mismatch flag stays after can0 up"
    [ "$(reg 8232)/$(reg 8233)" = 0x0007/0xA120 ] || fail "check: interface rate $(reg 8232)/$(reg 8233)"
    wait_until 5 log_has 'interface can0 is up at 500 kbit/s' || fail "check: no 'is up' line"
fi
reg_is 8192 0x0002 || fail "gateway left Data_Exch"
round_trip "0x0A0B 0x0C0D 0x0E0F" 0B0A0F0E0D0C 0x0E0F
echo "$CASE: manual §5.1.4 round trip on can0 <-> can1 at 500 kbit/s OK"

if [ "$CASE" = apply-down ]; then
    # Taken down by hand later: bus-off, the command in the log (candp2d does not fight the
    # operator), and a clean recovery when it is up again: frames flow both ways on the same socket.
    $IP link set can0 down
    wait_until 5 bus_is bus-off || fail "can0 down by hand: $(bus_text)"
    wait_until 10 log_has 'interface can0 is down: the gateways on it report bus-off until it is up at 500 kbit/s (Set_Prm of gateway gw5): `ip link set can0 up`' ||
        fail "no 'is down' line after ip link set can0 down: $(cat /out/candp2d.log)"
    run_logged_command
    wait_until 5 bus_is ok || fail "can0 up again: $(bus_text)"
    round_trip "0x1112 0x1314 0x1516" 121116151413 0x1516
    echo "$CASE: taken down and up again by hand: recovered, round trip OK"
fi
grep -E 'socketcan can0|bit rate' /out/candp2d.log | head -20
echo "PASS: $CASE"

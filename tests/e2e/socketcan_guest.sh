# candp2d on real SocketCAN inside the QEMU guest of tools/qemu/run-guest: the manual §5.1.4 round
# trip with mbpoll, candump and cansend, the controller state in diagnosis byte 8 / LED C / the
# status block, the bit rate registers, and the clear error for a missing interface. The same
# checks run on two interface kinds (first argument):
#   vcan     candp2d and the can-utils on vcan0 ("bitrate": "check"; vcan has no bit timing)
#   sja1000  candp2d on can0 with "bitrate": "apply" (500 kbit/s from Set_Prm), the can-utils on
#            can1 at 500 kbit/s: two emulated SJA1000 on one QEMU CAN bus (run-guest --sja1000)
# Run by ctest (label qemu) as:
#   run-guest [--sja1000] --bin build/bin/candp2d --bin /usr/bin/mbpoll \
#       --file config/socketcan.json:/etc/candp2/candp2d.json \
#       --file build/generated/registers.sh:/etc/candp2/registers.sh \
#       --script tests/e2e/socketcan_guest.sh -- vcan|sja1000
# registers.sh holds the register numbers of candp2d's own map for config/socketcan.json
# (python3 -m candp2 map --shell, docs/python.md): no register number is written here.
. /etc/candp2/guest-lib.sh
. /etc/candp2/registers.sh
IP=/usr/local/bin/iproute2-ip # iproute2 (run-guest --sja1000); busybox ip cannot set bit timing

KIND=${1:-vcan}
case $KIND in
vcan)
    IF=vcan0 PEER=vcan0 MODE=1
    cp /etc/candp2/candp2d.json /tmp/candp2d.json
    ;;
sja1000)
    IF=can0 PEER=can1 MODE=2
    # can0 starts at 125 kbit/s: candp2d must change it to the Set_Prm's 500 kbit/s.
    $IP link set can0 type can bitrate 125000 || fail "can0 bit rate"
    $IP link set can1 type can bitrate 500000 || fail "can1 bit rate"
    $IP link set can0 up && $IP link set can1 up || fail "can0/can1 up"
    # manual §5.1.2: "CAN-Bitrate" 500k = Set_Prm byte 8 index 2
    # (docs/dp-slave.md "User parameters").
    sed -e 's/"interface": "vcan0"/"interface": "can0", "bitrate": "apply", "restart_ms": 100/' \
        -e 's/"can_bitrate": "125k"/"can_bitrate": "500k"/' \
        /etc/candp2/candp2d.json >/tmp/candp2d.json
    ;;
*) fail "unknown interface kind $KIND (vcan or sja1000)" ;;
esac

# reg ADDRESS: one input register of unit 5 (the gateway's status block), as 0xNNNN.
reg() {
    mbpoll -m tcp -p 1502 -a 5 -0 -r "$1" -t 3:hex -1 127.0.0.1 2>/dev/null |
        sed -n "s/^\[$1\]:[[:space:]]*//p"
}
reg_is() { [ "$(reg "$1")" = "$2" ]; }
# Status block (docs/modbus.md): dp_state, diagnosis byte 8, bus_state, led_c, bitrate_mode,
# bitrate_configured and bitrate_interface (32 bit, high word first), bitrate_mismatch.
DIAG8=$((STATUS_DIAG + 8))
BR_MODE=$STATUS_BITRATE_MODE BR_MISMATCH=$STATUS_BITRATE_MISMATCH
BR_CONF=$STATUS_BITRATE_CONFIGURED BR_CONF_LO=$((STATUS_BITRATE_CONFIGURED + 1))
BR_IF=$STATUS_BITRATE_INTERFACE BR_IF_LO=$((STATUS_BITRATE_INTERFACE + 1))
# manual §5.1.4 slots of gateway 5: input slot 0 (I 172..177), output slot 1 (Q 172..177).
IN_FIRST=$GW5_SLOT0_FIRST IN_LAST=$GW5_SLOT0_LAST OUT_FIRST=$GW5_SLOT1_FIRST

# A missing interface: exit status 1 and a message naming it.
sed "s/\"interface\": \"$IF\"/\"interface\": \"${IF}9\"/" /tmp/candp2d.json >/tmp/missing.json
candp2d --config /tmp/missing.json >/tmp/missing.log 2>&1
rc=$?
[ "$rc" = 1 ] || fail "missing interface: exit status $rc, expected 1"
grep -q "cannot open SocketCAN interface ${IF}9" /tmp/missing.log ||
    fail "no clear error: $(cat /tmp/missing.log)"

candp2d --config /tmp/candp2d.json >/out/candp2d.log 2>&1 &
wait_tcp_listen 1502
timeout 20 candump -L -n 1 "$PEER,309:7FF" >/tmp/dump.log &
dump=$!
wait_can_receiver "$PEER"
# dp_state = 2: the master has the gateway in Data_Exch.
wait_until 10 reg_is $STATUS_DP_STATE 0x0002 || fail "gateway not in Data_Exch: $(cat /out/candp2d.log)"

if [ "$KIND" = sja1000 ]; then
    # "bitrate": "apply": the Set_Prm's 500 kbit/s is on can0 (down, bit rate, up through netlink).
    $IP -details link show can0 | tee /out/can0-apply.txt | grep -q 'bitrate 500000 ' ||
        fail "can0 not at 500 kbit/s: $(cat /out/can0-apply.txt)"
    grep -q 'restart-ms 100' /out/can0-apply.txt || fail "restart-ms 100 not applied"
    grep -q 'bit rate set to 500 kbit/s from the Set_Prm of gateway gw5 (was 125 kbit/s)' \
        /out/candp2d.log || fail "no log line for the bit rate change"
    # The down/up reached the raw socket as ENETDOWN with the interface already up again: a
    # restart (error-active), not a bus-off.
    grep -q 'interface was restarted (down and up); controller error-active' /out/candp2d.log ||
        fail "restart after the bit rate change not recognised"
    reg_is $STATUS_BUS_STATE 0x0000 || fail "bus state $(reg $STATUS_BUS_STATE) after the bit rate change"
    expect_configured=0x0007/0xA120 expect_interface=0x0007/0xA120 # 500000 bit/s
else
    # vcan has no bit timing: said once at info, no warning, interface bit rate 0.
    [ "$(grep -c 'no bit timing (virtual interface)' /out/candp2d.log)" = 1 ] ||
        fail "vcan: expected one 'no bit timing' line"
    expect_configured=0x0001/0xE848 expect_interface=0x0000/0x0000 # 125000 bit/s (Set_Prm)
fi
reg_is $BR_MODE "0x000$MODE" || fail "bitrate_mode $(reg $BR_MODE), expected $MODE"
[ "$(reg $BR_CONF)/$(reg $BR_CONF_LO)" = "$expect_configured" ] ||
    fail "bitrate_configured $(reg $BR_CONF)/$(reg $BR_CONF_LO)"
[ "$(reg $BR_IF)/$(reg $BR_IF_LO)" = "$expect_interface" ] ||
    fail "bitrate_interface $(reg $BR_IF)/$(reg $BR_IF_LO)"
reg_is $BR_MISMATCH 0x0000 || fail "bitrate_mismatch set"

# manual §5.1.4: Q 172..177 = holding registers OUT_FIRST..; form B8: a b c d e f -> b a f e d c.
mbpoll -m tcp -p 1502 -a 5 -0 -r $OUT_FIRST -t 4:hex -1 127.0.0.1 0x0A0B 0x0C0D 0x0E0F \
    >/dev/null || fail "mbpoll write"
wait $dump || fail "no frame 0x309 on $PEER"
grep -q " $PEER 309#0B0A0F0E0D0C$" /tmp/dump.log || fail "wrong frame: $(cat /tmp/dump.log)"
cansend "$PEER" 289#0B0A0F0E0D0C
wait_until 5 sh -c "mbpoll -m tcp -p 1502 -a 5 -0 -r $IN_FIRST -c 3 -t 3:hex -1 127.0.0.1 |
    grep -q '\[$IN_LAST\]:[[:space:]]*0x0E0F'" || fail "input image not updated"
mbpoll -m tcp -p 1502 -a 5 -0 -r $IN_FIRST -c 3 -t 3:hex -1 127.0.0.1 |
    grep -q "\[$IN_FIRST\]:[[:space:]]*0x0A0B" || fail "input register $IN_FIRST"
echo "candp2d on SocketCAN ($KIND): round trip OK"

# Controller state (docs/dp-slave.md "Diagnosis" diag byte 8, manual table 3.3.1 LED C) with
# CAN-Diagnosis on.
reg_is $DIAG8 0x0000 && reg_is $STATUS_LED_C 0x0001 ||
    fail "bus not ok at start: diag8 $(reg $DIAG8) led_c $(reg $STATUS_LED_C)"
if [ "$KIND" = vcan ]; then
    # The kernel's error frames as a controller driver sends them (linux/can/error.h):
    # CAN_ERR_CRTL with data[1] = CAN_ERR_CRTL_TX_PASSIVE (0x20) -> error-passive;
    cansend vcan0 20000004#0020000000000000
    wait_until 5 reg_is $DIAG8 0x0080 || fail "error-passive: diag byte 8 $(reg $DIAG8)"
    reg_is $STATUS_LED_C 0x0045 && reg_is $STATUS_BUS_STATE 0x0002 ||
        fail "error-passive: led_c $(reg $STATUS_LED_C) bus_state $(reg $STATUS_BUS_STATE)"
    cansend vcan0 20000040#0000000000000000 # CAN_ERR_BUSOFF
    wait_until 5 reg_is $DIAG8 0x00C0 || fail "bus-off: diag byte 8 $(reg $DIAG8)"
    reg_is $STATUS_LED_C 0x004F || fail "bus-off: led_c $(reg $STATUS_LED_C)"
    cansend vcan0 20000100#0000000000000000 # CAN_ERR_RESTARTED (restart-ms expired)
    wait_until 5 reg_is $DIAG8 0x0000 || fail "restarted: diag byte 8 $(reg $DIAG8)"
else
    # The SJA1000 driver's real transitions: can0 down = stopped (bus-off for the gateway) ...
    $IP link set can0 down
    wait_until 5 reg_is $DIAG8 0x00C0 || fail "can0 down: diag byte 8 $(reg $DIAG8)"
    reg_is $STATUS_LED_C 0x004F && reg_is $STATUS_BUS_STATE 0x0003 ||
        fail "can0 down: led_c $(reg $STATUS_LED_C) bus_state $(reg $STATUS_BUS_STATE)"
    # ... and up again: the controller restarts error-active; the next frame proves the link.
    $IP link set can0 up
    cansend can1 289#0102030405060708
    wait_until 5 reg_is $DIAG8 0x0000 || fail "can0 up: diag byte 8 $(reg $DIAG8)"
    reg_is $STATUS_LED_C 0x0001 || fail "can0 up: led_c $(reg $STATUS_LED_C)"
    $IP -details link show can0 | grep -q 'state ERROR-ACTIVE' || fail "can0 not error-active"
fi
reg_is $STATUS_DP_STATE 0x0002 || fail "gateway left Data_Exch"
echo "candp2d on SocketCAN ($KIND): controller state OK"

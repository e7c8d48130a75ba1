#!/bin/sh
# Guest script for run-guest --sja1000 (tests/qemu/CMakeLists.txt): candp2d's SocketCAN bit rate
# handling on a real driver (docs/transports.md "Bit rate"), manual §5.1.2 Set_Prm "CAN-Bitrate":
#  1. "apply" with a Set_Prm of 250 kbit/s (byte 8 = 4) changes can0 from 500 to 250 kbit/s;
#  2. "check" with a Set_Prm of 500 kbit/s leaves can0 at 250 kbit/s and reports the mismatch
#     (log warning, status field bitrate_mismatch = 1);
#  3. "apply" without CAP_NET_ADMIN (uid 65534): a log line naming CAP_NET_ADMIN and how to grant
#     it, the gateway keeps running, the mismatch is shown as in check.
# /etc/candp2/candp2d.json is config/socketcan.json (vcan0, 125k); /etc/candp2/registers.sh the
# register numbers of candp2d's own map (python3 -m candp2 map --shell, docs/python.md).
set -u
. /etc/candp2/guest-lib.sh
. /etc/candp2/registers.sh
# Status block (docs/modbus.md): dp_state; bitrate_mode, bitrate_configured and
# bitrate_interface (32 bit, high word first), bitrate_mismatch.
DP=$STATUS_DP_STATE MODE=$STATUS_BITRATE_MODE MISMATCH=$STATUS_BITRATE_MISMATCH
CONF=$STATUS_BITRATE_CONFIGURED CONF_LO=$((STATUS_BITRATE_CONFIGURED + 1))
IFR=$STATUS_BITRATE_INTERFACE IFR_LO=$((STATUS_BITRATE_INTERFACE + 1))
IP=/usr/local/bin/iproute2-ip

$IP link set can0 type can bitrate 500000 && $IP link set can0 up || fail "can0 at 500k"
$IP link set can1 type can bitrate 500000 && $IP link set can1 up || fail "can1 at 500k"

reg() {
    mbpoll -m tcp -p 1502 -a 5 -0 -r "$1" -t 3:hex -1 127.0.0.1 2>/dev/null |
        sed -n "s/^\[$1\]:[[:space:]]*//p"
}
reg_is() { [ "$(reg "$1")" = "$2" ]; }
# config MODE RATE: the example configuration on can0 with "bitrate": MODE and Set_Prm RATE.
config() {
    sed -e "s/\"interface\": \"vcan0\"/\"interface\": \"can0\", \"bitrate\": \"$1\"/" \
        -e "s/\"can_bitrate\": \"125k\"/\"can_bitrate\": \"$2\"/" /etc/candp2/candp2d.json
}
# run NAME [USER]: candp2d on /tmp/NAME.json (as USER) until the gateway is in Data_Exch.
run() {
    name=$1
    if [ $# -gt 1 ]; then # busybox su as root asks no password; exec keeps the pid
        su -s /bin/sh "$2" -c "exec candp2d --config /tmp/$name.json" >"/out/$name.log" 2>&1 &
    else
        candp2d --config "/tmp/$name.json" >"/out/$name.log" 2>&1 &
    fi
    pid=$!
    wait_tcp_listen 1502
    wait_until 10 reg_is $DP 0x0002 || fail "$name: gateway not in Data_Exch: $(cat /out/$name.log)"
}
stop() {
    kill "$pid"
    wait "$pid"
    wait_until 5 sh -c '! netstat -ltn | grep -q ":1502 "' || fail "port 1502 still in use"
}
rate_is() { $IP -details link show can0 | grep -q "bitrate $1 "; }

# 1. apply: 500 -> 250 kbit/s (docs/dp-slave.md "User parameters" byte 8 index 4 = 250k = 0x0003D090
# bit/s).
config apply 250k >/tmp/apply250.json
run apply250
rate_is 250000 || fail "apply: can0 not at 250 kbit/s: $($IP -details link show can0)"
grep -q 'bit rate set to 250 kbit/s from the Set_Prm of gateway gw5 (was 500 kbit/s)' \
    /out/apply250.log || fail "apply: no log line"
[ "$(reg $MODE)/$(reg $CONF)/$(reg $CONF_LO)/$(reg $MISMATCH)" = 0x0002/0x0003/0xD090/0x0000 ] ||
    fail "apply: status $(reg $MODE)/$(reg $CONF)/$(reg $CONF_LO)/$(reg $MISMATCH)"
stop
echo "apply: can0 re-parameterized 500 -> 250 kbit/s"

# 2. check: Set_Prm says 500k (0x0007A120), can0 runs at 250k (0x0003D090).
config check 500k >/tmp/check500.json
run check500
wait_until 5 reg_is $MISMATCH 0x0001 || fail "check: no mismatch flag"
[ "$(reg $MODE)/$(reg $CONF)/$(reg $CONF_LO)/$(reg $IFR)/$(reg $IFR_LO)" = \
    0x0001/0x0007/0xA120/0x0003/0xD090 ] ||
    fail "check: status $(reg $MODE)/$(reg $CONF)/$(reg $CONF_LO)/$(reg $IFR)/$(reg $IFR_LO)"
grep -q 'warning.*bit rate mismatch: gateway gw5 is parameterized for 500 kbit/s (Set_Prm byte 8), the interface runs at 250 kbit/s' \
    /out/check500.log || fail "check: no warning: $(cat /out/check500.log)"
rate_is 250000 || fail "check changed can0"
stop
echo "check: mismatch 500 vs 250 kbit/s reported"

# 3. apply without CAP_NET_ADMIN: uid 65534 has no capabilities.
echo 'nobody:x:65534:65534:nobody:/:/bin/sh' >>/etc/passwd
echo 'nogroup:x:65534:' >>/etc/group
config apply 500k >/tmp/noperm.json
run noperm nobody
wait_until 5 reg_is $MISMATCH 0x0001 || fail "no-permission: no mismatch flag"
grep -q 'CAP_NET_ADMIN' /out/noperm.log || fail "no-permission: no CAP_NET_ADMIN line: $(cat /out/noperm.log)"
grep -q 'candp2d-bitrate-apply.conf' /out/noperm.log || fail "no-permission: drop-in not named"
# ... and exactly what to run instead, with the real values (can0 is up at 250k: down first).
grep -qF 'run `ip link set can0 down && ip link set can0 type can bitrate 500000 && ip link set can0 up` as root' \
    /out/noperm.log || fail "no-permission: no command to run: $(cat /out/noperm.log)"
rate_is 250000 || fail "no-permission: can0 changed"
reg_is $DP 0x0002 || fail "no-permission: gateway left Data_Exch"
stop
grep -h 'CAP_NET_ADMIN' /out/noperm.log | head -1
echo "PASS: bit rate apply, re-parameterization, check and missing CAP_NET_ADMIN on the SJA1000"

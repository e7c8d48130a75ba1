# Helpers for guest scripts of tools/qemu/run-guest (busybox ash). The image has this file at
# /etc/candp2/guest-lib.sh; a guest script uses it with:  . /etc/candp2/guest-lib.sh
# Waits poll an observable condition every 20 ms and are always bounded.

# fail MESSAGE...: prints "FAIL: MESSAGE" and ends the guest script with exit code 1.
fail() {
    echo "FAIL: $*"
    exit 1
}

# _uptime_cs: sets _up_cs to the guest's uptime in centiseconds (/proc/uptime: "12.34 ...").
_uptime_cs() {
    read -r _up_raw _up_idle </proc/uptime
    _up_frac=${_up_raw#*.}
    _up_cs=$((${_up_raw%.*} * 100 + ${_up_frac#0}))
}

# wait_until SECONDS COMMAND [ARGS...]: runs COMMAND every 20 ms until it succeeds (returns 0) or
# SECONDS have passed on the guest clock (returns 1). COMMAND's output is discarded.
wait_until() {
    _uptime_cs
    _wu_deadline=$((_up_cs + $1 * 100))
    shift
    until "$@" >/dev/null 2>&1; do
        _uptime_cs
        [ "$_up_cs" -lt "$_wu_deadline" ] || return 1
        usleep 20000
    done
    return 0
}

# can_receiver_on IFACE: true when some CAN socket has a receive filter registered on IFACE
# (e.g. candump has bound to it), per the kernel's receive lists in /proc/net/can/.
can_receiver_on() {
    grep -q "^ *$1 " /proc/net/can/rcvlist_all /proc/net/can/rcvlist_fil \
        /proc/net/can/rcvlist_inv /proc/net/can/rcvlist_sff /proc/net/can/rcvlist_eff 2>/dev/null
}

# tcp_listening PORT: true when a TCP socket listens on PORT (any address).
tcp_listening() {
    netstat -ltn 2>/dev/null | grep -q "[:.]$1 "
}

# wait_can_receiver IFACE [SECONDS=10] / wait_tcp_listen PORT [SECONDS=10]: fail() on timeout.
wait_can_receiver() {
    wait_until "${2:-10}" can_receiver_on "$1" || fail "no CAN receiver on $1 after ${2:-10} s"
}
wait_tcp_listen() {
    wait_until "${2:-10}" tcp_listening "$1" ||
        fail "nothing listens on TCP port $1 after ${2:-10} s"
}

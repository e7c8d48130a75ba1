#!/bin/sh
# candp2 QEMU guest init (PID 1 under busybox ash), put into the image as /init by
# tools/qemu/run-guest with the @NAME@ placeholders filled in (runguest/image.py). Everything that
# can fail reports @MARK_SETUP_FAILED@ so the host can tell a broken image from a failing script.
export PATH=@GUEST_PATH@
export HOME=/root TERM=dumb CANDP2_GUEST=1

poweroff_now() {
    sync
    poweroff -f
    sleep 2
    reboot -f # -no-reboot turns a reboot into QEMU exiting as well
}
fail() {
    echo "@MARK_SETUP_FAILED@ $*"
    poweroff_now
}
uptime_s() { cut -d' ' -f1 /proc/uptime; }
user_processes_left() { # besides PID 1; kernel threads have no /proc/PID/exe target
    for exe in /proc/[0-9]*/exe; do
        [ "$exe" != /proc/1/exe ] && [ -e "$exe" ] && return 0
    done
    return 1
}

mount -t proc proc /proc || fail "mount /proc"
mount -t sysfs sysfs /sys || fail "mount /sys"
mount -t devtmpfs devtmpfs /dev || fail "mount /dev"
mkdir -p /dev/pts /dev/shm
mount -t devpts devpts /dev/pts || fail "mount /dev/pts"
mount -t tmpfs tmpfs /dev/shm || fail "mount /dev/shm"
mount -t tmpfs tmpfs /tmp || fail "mount /tmp"
mount -t tmpfs tmpfs /run || fail "mount /run"
hostname candp2-guest

while read -r mod; do
    [ -n "$mod" ] || continue
    insmod "$mod" || fail "insmod $mod"
done </etc/candp2/modules

ip link set lo up || fail "ip link set lo up"
ip link add dev vcan0 type vcan || fail "ip link add dev vcan0 type vcan"
ip link set up vcan0 || fail "ip link set up vcan0"
# --sja1000: the PCI CAN boards' interfaces appear while their driver probes; left down and
# unconfigured (the script sets the bit rate with iproute2-ip).
if [ -r /etc/candp2/expect-ifaces ]; then
    for dev in $(cat /etc/candp2/expect-ifaces); do
        i=0
        while [ ! -e "/sys/class/net/$dev" ]; do
            [ "$i" -lt 250 ] || fail "network interface $dev did not appear"
            usleep 20000
            i=$((i + 1))
        done
    done
fi

[ -r /etc/candp2/script ] || fail "no guest script in the image"
mkdir -p /out
cd /tmp || fail "cd /tmp"

eval "set -- $(cat /etc/candp2/args)"
echo # the firmware leaves the cursor mid-line; the marker must start a line
echo "@MARK_BEGIN@ uptime=$(uptime_s)"
/bin/sh /etc/candp2/script "$@" </dev/null
rc=$?
echo "@MARK_END@ uptime=$(uptime_s)"

# End what the script left running (daemons, candump &): SIGTERM, up to 2 s to exit, SIGKILL.
kill -TERM -1 2>/dev/null
i=0
while [ "$i" -lt 20 ] && user_processes_left; do
    usleep 100000
    i=$((i + 1))
done
kill -KILL -1 2>/dev/null

if [ -e /etc/candp2/collect-out ]; then
    echo "@MARK_OUT_BEGIN@"
    tar -cf - -C /out . | gzip -c | base64
    echo "@MARK_OUT_END@"
fi
echo "@MARK_EXIT@$rc"
poweroff_now

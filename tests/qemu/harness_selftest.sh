#!/bin/sh
# Host-side checks of tools/qemu/run-guest itself: a failing guest script, a guest that never
# finishes, a kernel that cannot boot and a broken guest setup must all be reported as failures
# with the documented exit codes (tools/qemu/README.md: script's code, 124 timeout, 125 harness).
#
# usage: harness_selftest.sh CASE RUN_GUEST WORK_DIR CACHE_DIR
set -u
case_name=$1
run_guest=$2
work=$3
cache=$4
here=$(cd "$(dirname "$0")" && pwd)

fail() {
    echo "FAIL [$case_name]: $*"
    exit 1
}

rm -rf "$work"
mkdir -p "$work"

# run_harness ARGS...: runs run-guest, stdout -> $work/stdout, stderr -> $work/stderr, rc -> $rc
run_harness() {
    start=$(date +%s)
    /usr/bin/python3 "$run_guest" --cache-dir "$cache" "$@" >"$work/stdout" 2>"$work/stderr"
    rc=$?
    elapsed=$(($(date +%s) - start))
    echo "--- run-guest stdout"
    cat "$work/stdout"
    echo "--- run-guest stderr"
    cat "$work/stderr"
    echo "--- run-guest exit code $rc after ${elapsed} s"
}

expect_line() { # FILE FIXED-STRING: a whole line must equal the string
    grep -qxF -- "$2" "$1" || fail "expected line '$2' in $(basename "$1")"
}
expect_text() { # FILE FIXED-STRING: somewhere in the file
    grep -qF -- "$2" "$1" || fail "expected '$2' in $(basename "$1")"
}

case "$case_name" in
failing-script)
    printf 'payload for the guest\n' >"$work/data.txt"
    run_harness --script "$here/guest_selftest.sh" --out-dir "$work/out" \
        --file "$work/data.txt:/etc/selftest/data.txt" \
        --bin /usr/bin/sha256sum:/usr/local/bin/host-sha256sum \
        -- one "two words"
    [ "$rc" -eq 3 ] || fail "expected the guest script's exit code 3, got $rc"
    expect_line "$work/stdout" "selftest args: 2 [one] [two words]"
    expect_line "$work/stdout" "selftest env: CANDP2_GUEST=1 cwd=/tmp"
    expect_line "$work/stdout" "selftest about to exit 3"
    expect_line "$work/stdout" "CANDP2-GUEST-EXIT=3"
    expect_text "$work/stderr" "guest script exit code 3"
    [ "$(cat "$work/out/result.txt")" = "written in the guest" ] ||
        fail "/out/result.txt not copied"
    want=$(sha256sum "$work/data.txt" | cut -d' ' -f1)
    [ "$(cat "$work/out/sub/sha256.txt")" = "$want" ] ||
        fail "--file/--bin: guest sha256 '$(cat "$work/out/sub/sha256.txt")' != host '$want'"
    ;;
timeout)
    printf 'echo "sleeping"\nsleep 600\n' >"$work/sleep.sh"
    run_harness --script "$work/sleep.sh" --timeout 20
    [ "$rc" -eq 124 ] || fail "expected exit code 124 (timeout), got $rc"
    expect_text "$work/stderr" "FAILED: timeout after 20 s"
    [ "$elapsed" -lt 60 ] || fail "the harness took ${elapsed} s to enforce a 20 s timeout"
    ;;
boot-failure)
    printf 'not a kernel\n' >"$work/bogus-kernel"
    printf 'echo "must not run"\n' >"$work/never.sh"
    run_harness --script "$work/never.sh" --kernel "$work/bogus-kernel" --timeout 60
    [ "$rc" -eq 125 ] || fail "expected exit code 125 (guest did not boot), got $rc"
    expect_text "$work/stderr" "FAILED: QEMU exited before the guest script started"
    if grep -qF "must not run" "$work/stdout"; then fail "the script ran"; fi
    ;;
setup-failure)
    # Replace the image's module list with a module that does not exist: init must report it.
    printf '/lib/modules/missing.ko\n' >"$work/modules"
    printf 'echo "must not run"\n' >"$work/never.sh"
    run_harness --script "$work/never.sh" --file "$work/modules:/etc/candp2/modules"
    [ "$rc" -eq 125 ] || fail "expected exit code 125 (guest setup failed), got $rc"
    expect_text "$work/stderr" "FAILED: guest setup failed: insmod /lib/modules/missing.ko"
    if grep -qF "must not run" "$work/stdout"; then fail "the script ran"; fi
    ;;
*)
    fail "unknown case"
    ;;
esac
echo "PASS [$case_name]"

#!/bin/sh
# Guest script for harness_selftest.sh "failing-script": exercises the run-guest interface (script
# arguments, --file, --bin with shared libraries, /out collection), then fails on purpose.
echo "selftest args: $# [${1-}] [${2-}]"
echo "selftest env: CANDP2_GUEST=${CANDP2_GUEST-unset} cwd=$(pwd)"
mkdir -p /out/sub
echo "written in the guest" >/out/result.txt
# --bin /usr/bin/sha256sum:/usr/local/bin/host-sha256sum (a dynamically linked host program)
host-sha256sum /etc/selftest/data.txt | cut -d' ' -f1 >/out/sub/sha256.txt
echo "selftest about to exit 3"
exit 3

#!/bin/bash
# packages_test.sh SETUP_SH: what `SETUP_SH packages run|test|deb` prints.
#  - `run` lists none of what only the tests or the package need: no QEMU, no kernel image, no
#    Chromium, no lintian, no clang, no libFuzzer runtime (libclang-rt), no GoogleTest;
#  - run ⊂ deb ⊂ test, no duplicates, and `test` has what the QEMU guest and the fuzzers need;
#  - every package listed is in Debian's index (apt-cache), so a typo fails here and not on a
#    user's fresh machine;
#  - an unknown command is a usage error (exit 2).
set -u
setup=$1
status=0
fail() {
  echo "FAIL: $*"
  status=1
}

run=$(bash "$setup" packages run) || fail "packages run: exit $?"
deb=$(bash "$setup" packages deb) || fail "packages deb: exit $?"
test=$(bash "$setup" packages test) || fail "packages test: exit $?"
[ -n "$run" ] || fail "packages run printed nothing"

forbidden=$(grep -E '^(qemu|linux-image|chromium|lintian$|clang|libclang|llvm|libfuzzer|libgtest|libgmock)' <<<"$run")
[ -z "$forbidden" ] || fail "packages run lists what only tests or packaging need: $(tr '\n' ' ' <<<"$forbidden")"

for p in build-essential cmake libsocketcan-dev libmodbus-dev libmicrohttpd-dev libsystemd-dev; do
  grep -qx "$p" <<<"$run" || fail "packages run lacks $p (the Release build needs it)"
done
for p in qemu-system-x86 linux-image-amd64 busybox-static chromium libclang-rt-14-dev libgtest-dev; do
  grep -qx "$p" <<<"$test" || fail "packages test lacks $p"
done
grep -qx lintian <<<"$deb" || fail "packages deb lacks lintian"

subset() {  # A B NAME: every line of A is in B
  local missing
  missing=$(comm -23 <(sort <<<"$1") <(sort <<<"$2"))
  [ -z "$missing" ] || fail "$3: $(tr '\n' ' ' <<<"$missing")"
}
subset "$run" "$deb" "packages run has packages deb does not"
subset "$deb" "$test" "packages deb has packages test does not"
for list in run deb test; do
  dups=$(sort <<<"${!list}" | uniq -d)
  [ -z "$dups" ] || fail "packages $list lists twice: $dups"
  bad=$(grep -vE '^[a-z0-9][a-z0-9+.-]+$' <<<"${!list}")
  [ -z "$bad" ] || fail "packages $list: not a package name: $bad"
done

# Debian's index: one apt-cache call for all (installed packages are known even without lists).
if ! command -v apt-cache >/dev/null; then
  fail "apt-cache not found: cannot check the package names against Debian's index"
else
  # shellcheck disable=SC2086 # one word per package
  known=$(apt-cache show --no-all-versions $test 2>/dev/null | sed -n 's/^Package: //p' | sort -u)
  unknown=$(comm -23 <(sort -u <<<"$test") <(cat <<<"$known"))
  [ -z "$unknown" ] ||
    fail "not in Debian's index (apt-cache show; after apt-get update?): $(tr '\n' ' ' <<<"$unknown")"
fi

bash "$setup" packages nonsense >/dev/null 2>&1
rc=$?
[ $rc -eq 2 ] || fail "packages nonsense: exit $rc, expected 2"

echo "run: $(wc -l <<<"$run") packages, deb: $(wc -l <<<"$deb"), test: $(wc -l <<<"$test")"
[ $status -eq 0 ] && echo "PASS"
exit $status

#!/usr/bin/env bash
# candp2 set-up for a fresh Debian 12 machine (run as root, or with sudo available).
#
#   tools/setup.sh run    install what is needed, build (Release, warnings not fatal: what users
#                         build, in build-release/), run candp2d on its embedded default (virtual
#                         CAN bus, simulated drives, Modbus on 127.0.0.1:1502)
#   tools/setup.sh test   install what is needed, build, run every test: the run command's own
#                         build and a smoke test of it, the Debian package, unit and end-to-end
#                         tests, the unit tests again under ASan/UBSan, every libFuzzer target for a
#                         bounded time, and the SocketCAN tests inside a QEMU guest; a compiler
#                         warning in any of its builds fails it. Every stage prints its time, the
#                         end a table of them (docs/development.md "The test command")
#   tools/setup.sh deb    install what is needed, build, write dist/candp2_VERSION_ARCH.deb and
#                         dist/python3-candp2_VERSION_all.deb
#   tools/setup.sh deps [run|test|deb]   only install the packages (default: test, all of them)
#   tools/setup.sh packages run|test|deb print the packages that command installs, one a line
#
# Each command installs only what it uses: `run` what the Release build and the daemon need,
# `deb` adds packaging, `test` adds the tests (and builds the package too).
# Environment: CANDP2_FUZZ_SECONDS (default 20 per target), CANDP2_JOBS (default: nproc),
# CANDP2_STAGES (test: only the stages named, default all of them; see all_stages below).
# ccache is used when installed.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"
jobs=${CANDP2_JOBS:-$(nproc)}
fuzz_seconds=${CANDP2_FUZZ_SECONDS:-20}

# Debian packages, one purpose per line. tests/setup/packages_test.sh checks that `run` stays free
# of what only the tests need.
run_packages=(
  build-essential cmake ninja-build pkg-config git      # toolchain; git describe for --version
  libmodbus-dev nlohmann-json3-dev libcli11-dev         # Modbus/TCP, JSON configuration, CLI
  libspdlog-dev libfmt-dev                              # logging
  libsocketcan-dev                                      # SocketCAN bit rate and controller state (netlink)
  libmicrohttpd-dev libsystemd-dev                      # HTTP face; sd-daemon.h (journal priorities)
  mbpoll                                                # the Modbus client of the README's demo
)
deb_packages=(
  dpkg-dev lintian                                      # the .deb: dpkg-shlibdeps, dpkg-deb, lintian
  python3-pip python3-setuptools python3-wheel          # python3-candp2: its wheel, built offline
)
test_packages=(
  libgtest-dev libgmock-dev libbenchmark-dev            # tests and benchmarks
  clang-14 libclang-rt-14-dev clang-format              # libFuzzer, sanitizers, formatting
  can-utils                                             # independent CAN peer
  python3 python3-can python3-pymodbus python3-serial-asyncio # independent python peers (/usr/bin/python3)
  python3-pytest python3-pytest-xdist mypy flake8 python3-venv # the candp2 Python package: tests, typing, lint, pip install
  qemu-system-x86 linux-image-amd64 busybox-static iproute2 # the SocketCAN guest (vcan, SJA1000: ip)
  python3-prometheus-client chromium                    # /metrics and page tests
  systemd                                               # systemd-analyze verify
  tshark                                                # the Wireshark dissector's tests (docs/capture.md)
  ccache                                                # compiler cache for the many test builds
)

# packages_for run|test|deb: the whole list that command installs.
packages_for() {
  case $1 in
    run) printf '%s\n' "${run_packages[@]}" ;;
    deb) printf '%s\n' "${run_packages[@]}" "${deb_packages[@]}" ;;
    test) printf '%s\n' "${run_packages[@]}" "${deb_packages[@]}" "${test_packages[@]}" ;;
    *)
      echo "setup: unknown command '$1' (run, test or deb)" >&2
      return 2
      ;;
  esac
}

as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

install_deps() {  # run|test|deb
  local packages missing=()
  mapfile -t packages < <(packages_for "$1")
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then
    echo "setup: all ${#packages[@]} packages present"
    return
  fi
  echo "setup: installing ${missing[*]}"
  as_root env DEBIAN_FRONTEND=noninteractive apt-get update -q
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# ccache when present (any build directory, any checkout path).
launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  export CCACHE_BASEDIR="$here"
  # The -g builds (ASan, fuzz) hash the build folder unless told not to; without it a clone in
  # another folder never hits the cache for them (their debug info then names the first folder).
  export CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-1}
  # The sanitizer tree's test sources use one precompiled header (docs/development.md
  # "Precompiled test header"); ccache caches such a compilation only when told that it cannot see
  # the header's macros and times.
  export CCACHE_SLOPPINESS=${CCACHE_SLOPPINESS:-pch_defines,time_macros,include_file_mtime,include_file_ctime}
fi

configure_build() {  # DIR [cmake args...]
  local dir=$1
  shift
  cmake -S . -B "$dir" -G Ninja "${launcher[@]}" "$@" >/dev/null &&
    cmake --build "$dir" -j "$jobs"
}

# The run command's build, exactly what a user builds: Release, warnings not fatal (a new
# compiler's false positive must not stop a user's build), only the user-facing executables.
# `test` and `deb` use this very function and directory.
release_dir="build-release"
build_release() {
  cmake -S . -B "$release_dir" -G Ninja "${launcher[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DCANDP2_WERROR=OFF -DCANDP2_BENCH=OFF -DCANDP2_TESTS=OFF >/dev/null &&
    cmake --build "$release_dir" -j "$jobs" --target candp2d candp2 candp2-drive
}

run_daemon() {
  build_release
  echo "setup: starting $release_dir/bin/candp2d (Ctrl-C to stop)"
  exec "$release_dir/bin/candp2d" "$@"
}

# dist/candp2_VERSION_ARCH.deb from the run command's build and dist/python3-candp2_VERSION_all.deb
# (packaging/deb/build-deb.sh).
build_deb() {
  build_release
  packaging/deb/build-deb.sh "$release_dir" dist
}

# The sanitizer build (build-asan/): one clang tree, every object compiled once with ASan, UBSan
# and libFuzzer's coverage (CANDP2_FUZZ=ON and CANDP2_SANITIZE=ON), serves both the unit tests run
# under the sanitizers (the target candp2_unit_tests, stage asan-build) and the libFuzzer targets
# (the target candp2_fuzzers, stage fuzz-build: their mains and links only). No apps, no benches.
# -O1 -g without NDEBUG: the assertions stay on, at the optimisation AddressSanitizer recommends.
fuzz_dir="build-asan"
configure_sanitizers() {
  CC=clang-14 CXX=clang++-14 cmake -S . -B build-asan -G Ninja "${launcher[@]}" -DCANDP2_FUZZ=ON \
    -DCANDP2_SANITIZE=ON -DCANDP2_APPS=OFF -DCANDP2_BENCH=OFF -DCANDP2_WERROR=ON \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g" \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" >/dev/null
}
build_fuzzers() {
  configure_sanitizers && cmake --build "$fuzz_dir" -j "$jobs" --target candp2_fuzzers
}

# fuzz_one TARGET: one libFuzzer target for $fuzz_seconds on its corpus; its lines go to
# WORK.out, its verdict (ok, FAILED) to WORK.result.
fuzz_one() {
  local f=$1 name corpus work result=ok
  name=$(basename "$f")
  corpus="tests/fuzz/corpus/$name"
  work="$fuzz_dir/fuzz-work/$name"
  mkdir -p "$work"
  if [ -d "$corpus" ]; then cp -n "$corpus"/* "$work"/ 2>/dev/null || true; fi
  {
    echo "fuzz: $name for ${fuzz_seconds}s"
    if "$f" -max_total_time="$fuzz_seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
      -artifact_prefix="$work-" "$work" >"$work.log" 2>&1; then
      echo "fuzz: $name ok ($(grep -m1 -o 'stat::number_of_executed_units: [0-9]*' "$work.log"))"
    else
      echo "fuzz: $name FAILED"
      tail -40 "$work.log"
      result=FAILED
    fi
  } >"$work.out"
  echo "$result" >"$work.result"
}

# Every fuzz target, $jobs of them at a time (each one core, each its full time); their lines
# in the targets' order.
run_fuzzers() {
  local f name failed=0 ran=0 targets=()
  for f in "$fuzz_dir"/fuzz/*; do [ -x "$f" ] && targets+=("$f"); done
  mkdir -p "$fuzz_dir/fuzz-work"
  for f in "${targets[@]}"; do
    rm -f "$fuzz_dir/fuzz-work/$(basename "$f").result"
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
    fuzz_one "$f" &
  done
  wait
  for f in "${targets[@]}"; do
    name=$(basename "$f")
    cat "$fuzz_dir/fuzz-work/$name.out"
    [ "$(cat "$fuzz_dir/fuzz-work/$name.result" 2>/dev/null)" = ok ] || failed=$((failed + 1))
    ran=$((ran + 1))
  done
  echo "fuzz: $ran targets, $failed failed"
  stage_note="$ran targets, $failed failed"
  [ "$ran" -gt 0 ] && [ "$failed" -eq 0 ]
}

# Vendor files (docs/development.md "Vendor files"): the vendor GSD corpus and the vendor manuals
# are not part of the repository. When they lie beside the checkout (../shared) and the variables
# are not set already, the tests that check them run on them too; otherwise those tests (suite
# names VendorGsdCorpus.*, VendorManual.*) are skipped and the summary says how many.
vendor_setup() {
  local shared=$here/../shared
  if [ -z "${CANDP2_GSD_CORPUS:-}" ] && [ -d "$shared/gsd-corpus" ]; then
    CANDP2_GSD_CORPUS=$(cd "$shared/gsd-corpus" && pwd)
    export CANDP2_GSD_CORPUS
  fi
  if [ -z "${CANDP2_MANUALS:-}" ] && [ -d "$shared/spec" ]; then
    CANDP2_MANUALS=$(cd "$shared/spec" && pwd)
    export CANDP2_MANUALS
  fi
}

# vendor_summary: one line per vendor folder: where it was, or how many tests did not run (in
# build/ and, the unit ones, again in build-asan/).
vendor_summary() {
  local what var suite n dir
  for what in "vendor GSD corpus:CANDP2_GSD_CORPUS:VendorGsdCorpus" "vendor manuals:CANDP2_MANUALS:VendorManual"; do
    IFS=: read -r what var suite <<<"$what"
    n=0
    for dir in build build-asan; do
      [ -d "$dir" ] || continue
      n=$((n + $(ctest --test-dir "$dir" -N -L unit -R "^$suite\\." 2>/dev/null | grep -c 'Test *#' || true)))
    done
    if [ -n "${!var:-}" ]; then
      echo "setup: $what: ${!var} ($var), $n tests ran on it"
    else
      echo "setup: $what: not given, $n tests not run (set $var, docs/development.md)"
    fi
  done
}

# The names of the tests ctest recorded as failed in build directory $1, on one line.
ctest_failed() {
  local log=$1/Testing/Temporary/LastTestsFailed.log
  if [ -f "$log" ]; then cut -d: -f2- "$log" | tr '\n' ' '; else echo "(no list)"; fi
}

# failed_output DIR: the last 40 lines each failed test of DIR's last ctest printed, from ctest's
# own log (ctest_stage's copy of it). Printed again at the very end, beside the stage table: a CI
# log is read from its tail, and a test that failed early in a run of a thousand is far above it.
failed_output() {
  local dir=$1 name
  local failed=$dir/Testing/Temporary/LastTestsFailed.log all=$dir/ctest-tests.log
  [ -f "$failed" ] && [ -f "$all" ] || return 0
  for name in $(cut -d: -f2- "$failed"); do
    echo "setup: ---- the output of $name ($dir), its last 40 lines ----"
    awk -v name="$name" '
      $0 ~ /^[0-9]+\/[0-9]+ Test: / { sub(/^[0-9]+\/[0-9]+ Test: /, ""); mine = ($0 == name); next }
      mine && /^Output:$/ { getline; out = 1; next }
      mine && /^<end of output>$/ { out = 0; mine = 0; next }
      out { print }' "$all" | tail -40
  done
}

# ---- The test command's stages (docs/development.md "The test command: stages and times").
# Each stage prints its time; the end prints a table of every stage, its time and result, and the
# total, also when a stage failed (the tail of a CI log is what a contributor reads).
# CANDP2_STAGES (default: all) runs only the stages named, e.g. CANDP2_STAGES="fuzz-build fuzz-run".
all_stages="packages release smoke deb dev-build dev-test asan-build asan-test fuzz-build fuzz-run"
stage_rows=()   # the table, one line per stage
stage_note=""   # what a stage adds to its row (tests run, ccache hits), set by the stage
stage_failed=() # the keys of failed stages

# stage KEY NAME COMMAND...: run COMMAND as the stage KEY unless CANDP2_STAGES leaves it out;
# print its time, add its row.
stage() {
  local key=$1 name=$2 t=$SECONDS rc=0 result cclog hits misses
  shift 2
  case " ${CANDP2_STAGES:-$all_stages} " in *" $key "*) ;; *) return 0 ;; esac
  echo "== $name"
  stage_note=""
  # This stage's own compiler-cache hits and misses (ccache's stats log: other builds on the
  # machine do not count).
  cclog=$(mktemp)
  CCACHE_STATSLOG=$cclog "$@" || rc=$?
  hits=$(grep -cxE '(direct|preprocessed)_cache_hit' "$cclog" || true)
  misses=$(grep -cx cache_miss "$cclog" || true)
  rm -f "$cclog"
  if [ "$hits" -gt 0 ] || [ "$misses" -gt 0 ]; then
    stage_note="${stage_note:+$stage_note, }ccache $hits hits $misses misses"
  fi
  result=ok
  if [ $rc -ne 0 ]; then
    result="FAILED"
    stage_failed+=("$key")
  fi
  echo "setup: $name took $((SECONDS - t)) s ($result)"
  stage_rows+=("$(printf '%-36s %5d s  %s' "$name" $((SECONDS - t)) "$result${stage_note:+ ($stage_note)}")")
  return $rc
}

# not_run_after NAME BUILD_KEY: true (and a row saying so) when the build stage BUILD_KEY failed:
# the stage NAME that needs that build is not run.
not_run_after() {
  local name=$1 build=$2
  case " ${stage_failed[*]} " in
    *" $build "*)
      stage_rows+=("$(printf '%-36s %5s    %s' "$name" - "not run ($build failed)")")
      return 0
      ;;
  esac
  return 1
}

stage_table() {  # TOTAL_SECONDS
  echo "setup: ---- stages (time, result) ----"
  local row
  for row in "${stage_rows[@]}"; do echo "setup: $row"; done
  printf 'setup: %-36s %5d s\n' "total" "$1"
}

# ctest in build directory $1 with more arguments; the row notes how many tests ran.
ctest_stage() {
  local dir=$1 rc=0
  shift
  # ctest leaves an old list of failed tests in place when all pass: not to be reported again.
  rm -f "$dir/Testing/Temporary/LastTestsFailed.log"
  ctest --test-dir "$dir" --output-on-failure -j "$jobs" --timeout 600 "$@" | tee "$dir/ctest.log" ||
    rc=$?
  # Every later ctest in $dir (even `ctest -N`, as vendor_summary runs) rewrites LastTest.log:
  # failed_output reads this run's copy.
  cp -f "$dir/Testing/Temporary/LastTest.log" "$dir/ctest-tests.log" 2>/dev/null || true
  stage_note=$(grep -o '[0-9]* tests failed out of [0-9]*' "$dir/ctest.log" | tail -1)
  return $rc
}

# warning_check LOG WHAT: a build must be warning-free, though warnings do not stop it (a user's
# build, and the development build that shares its compiler flags): whatever LOG shows compiled is
# checked for compiler warnings here.
warning_check() {
  local log=$1 what=$2
  grep -q "warning:" "$log" || return 0
  echo "setup: the $what printed compiler warnings (see above)"
  # Our files the warnings name ("../http/x.cpp:52" in "inlined from ... at" and "In file
  # included from" lines), then the first warning itself.
  failures+=("$what: compiler warnings, at $(grep -o '\.\./[A-Za-z0-9_/.-]*\.[ch]pp:[0-9]*' \
    "$log" | sort -u | tr '\n' ' ')- $(grep -m1 'warning:' "$log")")
  return 1
}

# The run command's build (Release, warnings not fatal).
release_stage() {
  local log=$release_dir/build.log
  mkdir -p "$release_dir"
  if ! build_release 2>&1 | tee "$log"; then
    failures+=("Release build failed")
    return 1
  fi
  warning_check "$log" "Release build"
}

# The development build: everything (ctest runs every label on it). The very compiler flags of
# the Release build above (Release, warnings checked by warning_check rather than -Werror), so that
# every library and executable compiled there is a compiler-cache hit here: only the tests and
# benchmarks are compiled anew.
dev_build() {
  local log=build/build.log
  mkdir -p build
  if ! configure_build build -DCMAKE_BUILD_TYPE=Release -DCANDP2_WERROR=OFF 2>&1 | tee "$log"; then
    failures+=("dev build (build/) failed")
    return 1
  fi
  warning_check "$log" "dev build"
}

# The sanitizer build's unit tests: only what `ctest -L unit` runs (the target candp2_unit_tests).
asan_build() {
  configure_sanitizers && cmake --build build-asan -j "$jobs" --target candp2_unit_tests
}

run_tests() {
  vendor_setup
  local start=$SECONDS
  local failures=()  # one line per failed stage, repeated at the very end (CI shows the tail)

  stage packages "packages (apt)" install_deps test || failures+=("installing the packages")
  stage release "Release build (the run command's)" release_stage
  if ! not_run_after "smoke test of the Release candp2d" release; then
    stage smoke "smoke test of the Release candp2d" \
      /usr/bin/python3 tests/e2e/run_smoke.py --candp2d "$release_dir/bin/candp2d" ||
      failures+=("smoke test of the Release candp2d")
  fi
  # The Debian package from the Release build above (tested by ctest's deb_package).
  if ! not_run_after "Debian package (dist/)" release; then
    stage deb "Debian package (dist/)" packaging/deb/build-deb.sh "$release_dir" dist ||
      failures+=("Debian package build")
  fi

  stage dev-build "dev build (Release flags, all)" dev_build
  if ! not_run_after "ctest, every label (build/)" dev-build; then
    stage dev-test "ctest, every label (build/)" ctest_stage build ||
      failures+=("ctest (build): $(ctest_failed build)")
  fi

  stage asan-build "ASan/UBSan build (unit tests)" asan_build || failures+=("ASan/UBSan build")
  if ! not_run_after "ctest -L unit, ASan/UBSan" asan-build; then
    ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
      stage asan-test "ctest -L unit, ASan/UBSan" ctest_stage build-asan -L unit ||
      failures+=("ctest under sanitizers (build-asan): $(ctest_failed build-asan)")
  fi

  stage fuzz-build "libFuzzer build (fuzz targets)" build_fuzzers || failures+=("libFuzzer build")
  if ! not_run_after "libFuzzer, ${fuzz_seconds} s each" fuzz-build; then
    stage fuzz-run "libFuzzer, ${fuzz_seconds} s each" run_fuzzers ||
      failures+=("fuzzers (see fuzz: lines above)")
  fi

  vendor_summary
  case " ${stage_failed[*]} " in *" dev-test "*) failed_output build ;; esac
  case " ${stage_failed[*]} " in *" asan-test "*) failed_output build-asan ;; esac
  stage_table $((SECONDS - start))
  if [ ${#failures[@]} -eq 0 ]; then
    echo "setup: ALL TESTS PASSED"
    return 0
  fi
  local f
  for f in "${failures[@]}"; do echo "setup: FAILED: $f"; done
  echo "setup: SOME TESTS FAILED"
  return 1
}

case "${1:-}" in
  deps) install_deps "${2:-test}" ;;
  packages)
    [ $# -eq 2 ] || { echo "usage: $0 packages run|test|deb" >&2; exit 2; }
    packages_for "$2"
    ;;
  run) install_deps run; shift; run_daemon "$@" ;;
  test) run_tests ;;
  deb) install_deps deb; build_deb ;;
  *)
    echo "usage: $0 run|test|deb|deps [run|test|deb]|packages run|test|deb" >&2
    exit 2
    ;;
esac

#!/usr/bin/env bash
# candp2 set-up for a fresh Debian 12 machine (run as root, or with sudo available).
#
#   tools/setup.sh run    install what is needed, build (Release, warnings not fatal: what users
#                         build, in build-release/), run candp2d on its embedded default (virtual
#                         CAN bus, simulated drives, Modbus on 127.0.0.1:1502)
#   tools/setup.sh test   install what is needed, build, run every test: the run command's own
#                         build and a smoke test of it, the Debian package, unit and end-to-end
#                         tests, the unit tests again under ASan/UBSan, every libFuzzer target for a
#                         bounded time, and the SocketCAN tests inside a QEMU guest; development
#                         builds with warnings as errors (CANDP2_WERROR)
#   tools/setup.sh deb    install what is needed, build, write dist/candp2_VERSION_ARCH.deb and
#                         dist/python3-candp2_VERSION_all.deb
#   tools/setup.sh deps [run|test|deb]   only install the packages (default: test, all of them)
#   tools/setup.sh packages run|test|deb print the packages that command installs, one a line
#
# Each command installs only what it uses: `run` what the Release build and the daemon need,
# `deb` adds packaging, `test` adds the tests (and builds the package too).
# Environment: CANDP2_FUZZ_SECONDS (default 20 per target), CANDP2_JOBS (default: nproc).
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
fi

configure_build() {  # DIR [cmake args...]
  local dir=$1
  shift
  cmake -S . -B "$dir" -G Ninja "${launcher[@]}" "$@" >/dev/null
  cmake --build "$dir" -j "$jobs"
}

# The run command's build, exactly what a user builds: Release, warnings not fatal (a new
# compiler's false positive must not stop a user's build), only the user-facing executables.
# `test` and `deb` use this very function and directory.
release_dir=build-release
build_release() {
  cmake -S . -B "$release_dir" -G Ninja "${launcher[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DCANDP2_WERROR=OFF -DCANDP2_BENCH=OFF -DCANDP2_TESTS=OFF >/dev/null
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

run_fuzzers() {
  local dir=build-fuzz
  CC=clang-14 CXX=clang++-14 cmake -S . -B "$dir" -G Ninja "${launcher[@]}" -DCANDP2_FUZZ=ON \
    -DCANDP2_APPS=OFF -DCANDP2_BENCH=OFF -DCANDP2_WERROR=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    >/dev/null
  cmake --build "$dir" -j "$jobs"
  local failed=0 ran=0
  for f in "$dir"/fuzz/*; do
    [ -x "$f" ] || continue
    local name corpus
    name=$(basename "$f")
    corpus="tests/fuzz/corpus/$name"
    local work="$dir/fuzz-work/$name"
    mkdir -p "$work"
    [ -d "$corpus" ] && cp -n "$corpus"/* "$work"/ 2>/dev/null || true
    echo "fuzz: $name for ${fuzz_seconds}s"
    if "$f" -max_total_time="$fuzz_seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
      -artifact_prefix="$dir/fuzz-work/$name-" "$work" >"$dir/fuzz-work/$name.log" 2>&1; then
      echo "fuzz: $name ok ($(grep -m1 -o 'stat::number_of_executed_units: [0-9]*' "$dir/fuzz-work/$name.log"))"
    else
      echo "fuzz: $name FAILED"
      tail -40 "$dir/fuzz-work/$name.log"
      failed=$((failed + 1))
    fi
    ran=$((ran + 1))
  done
  echo "fuzz: $ran targets, $failed failed"
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

run_tests() {
  vendor_setup
  local status=0
  local failures=()  # one line per failed stage, repeated at the very end (CI shows the tail)
  local t=$SECONDS
  echo "== the run command's build (Release) and its smoke test"
  # A user's build must be warning-free too, though warnings do not stop it there:
  # whatever this build compiles is checked for compiler warnings here.
  local release_log=$release_dir/build.log
  mkdir -p "$release_dir"
  if build_release 2>&1 | tee "$release_log"; then
    if grep -q "warning:" "$release_log"; then
      echo "setup: the Release build printed compiler warnings (see above)"
      # Our files the warnings name ("../http/x.cpp:52" in "inlined from ... at" and "In file
      # included from" lines), then the first warning itself.
      failures+=("Release build: compiler warnings, at $(grep -o '\.\./[A-Za-z0-9_/.-]*\.[ch]pp:[0-9]*' \
        "$release_log" | sort -u | tr '\n' ' ')- $(grep -m1 'warning:' "$release_log")")
      status=1
    fi
  else
    failures+=("Release build failed")
    status=1
  fi
  /usr/bin/python3 tests/e2e/run_smoke.py --candp2d "$release_dir/bin/candp2d" ||
    { failures+=("smoke test of the Release candp2d"); status=1; }
  echo "setup: Release build and smoke test took $((SECONDS - t)) s"

  t=$SECONDS
  echo "== the Debian package (dist/), tested by ctest's deb_package"
  packaging/deb/build-deb.sh "$release_dir" dist || { failures+=("Debian package build"); status=1; }
  echo "setup: Debian package took $((SECONDS - t)) s"

  echo "== build and all tests (unit, e2e, replay, systemd, package, qemu)"
  configure_build build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCANDP2_WERROR=ON
  if ! ctest --test-dir build --output-on-failure -j "$jobs" --timeout 600; then
    failures+=("ctest (build): $(ctest_failed build)")
    status=1
  fi

  echo "== unit tests under AddressSanitizer + UndefinedBehaviorSanitizer"
  configure_build build-asan -DCMAKE_BUILD_TYPE=Debug -DCANDP2_SANITIZE=ON -DCANDP2_BENCH=OFF \
    -DCANDP2_APPS=OFF -DCANDP2_WERROR=ON
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
    ctest --test-dir build-asan --output-on-failure -j "$jobs" -L unit --timeout 600 ||
    { failures+=("ctest under sanitizers (build-asan): $(ctest_failed build-asan)"); status=1; }

  echo "== libFuzzer targets, ${fuzz_seconds}s each"
  run_fuzzers || { failures+=("fuzzers (see fuzz: lines above)"); status=1; }

  vendor_summary
  if [ $status -eq 0 ]; then
    echo "setup: ALL TESTS PASSED"
  else
    local f
    for f in "${failures[@]}"; do echo "setup: FAILED: $f"; done
    echo "setup: SOME TESTS FAILED"
  fi
  return $status
}

case "${1:-}" in
  deps) install_deps "${2:-test}" ;;
  packages)
    [ $# -eq 2 ] || { echo "usage: $0 packages run|test|deb" >&2; exit 2; }
    packages_for "$2"
    ;;
  run) install_deps run; shift; run_daemon "$@" ;;
  test) install_deps test; run_tests ;;
  deb) install_deps deb; build_deb ;;
  *)
    echo "usage: $0 run|test|deb|deps [run|test|deb]|packages run|test|deb" >&2
    exit 2
    ;;
esac

#!/usr/bin/env bash
# The Python examples on a loaded host (docs/daemon.md "Host stalls"): RUNS runs of
# `pytest -n 4 python/examples` beside two busy loops (a CI runner's other jobs), each run's
# verdict and the count of failed runs at the end. A measurement, not a test: run it by hand.
#   bench/flakiness.sh build/bin/candp2d [RUNS=20] [BUSY=2]
set -u
candp2d=$(realpath "${1:?usage: bench/flakiness.sh CANDP2D [RUNS] [BUSY]}")
runs=${2:-20}
busy=${3:-2}
here=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
pids=()
for _ in $(seq 1 "$busy"); do
  (while :; do :; done) &
  pids+=($!)
done
trap 'kill "${pids[@]}" 2>/dev/null; rm -rf "$work"' EXIT
failed=0
for i in $(seq 1 "$runs"); do
  start=$SECONDS
  if PYTHONPATH="$here/python" /usr/bin/python3 -m pytest -p candp2.pytest_plugin \
    -p no:cacheprovider -q -n 4 --candp2d "$candp2d" "$here/python/examples" >"$work/run" 2>&1; then
    echo "run $i: ok ($(tail -1 "$work/run")) in $((SECONDS - start)) s"
  else
    failed=$((failed + 1))
    echo "run $i: FAILED in $((SECONDS - start)) s"
    grep -E '^(FAILED|ERROR)|host stalls' "$work/run" | head -20
  fi
done
echo "flakiness: $runs runs beside $busy busy loops, $failed failed"
[ "$failed" -eq 0 ]

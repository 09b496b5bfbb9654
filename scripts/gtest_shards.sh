#!/usr/bin/env bash
# gtest_shards.sh BINARY SHARDS FILTER: runs a GoogleTest binary's tests (those FILTER, a
# --gtest_filter, selects) in SHARDS processes at once, GoogleTest's own sharding
# (GTEST_TOTAL_SHARDS, GTEST_SHARD_INDEX) splitting the tests among them. Prints each shard's
# summary line, and the whole output of a shard that fails; exits 1 when any shard fails.
# `make test-asan` runs the library's tests so: under AddressSanitizer a process takes 0.3-0.4 s
# to start, which ctest's one process per test paid a thousand times (docs/RELIABILITY.md).
set -uo pipefail
if [[ $# -ne 3 || ! -x $1 || ! $2 =~ ^[1-9][0-9]*$ ]]; then
  echo "usage: $0 BINARY SHARDS FILTER (BINARY an executable GoogleTest binary, SHARDS >= 1)" >&2
  exit 2
fi
binary=$1
shards=$2
filter=$3
logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT
pids=()
for ((i = 0; i < shards; ++i)); do
  GTEST_TOTAL_SHARDS=$shards GTEST_SHARD_INDEX=$i "$binary" --gtest_filter="$filter" \
    >"$logs/$i.log" 2>&1 &
  pids+=($!)
done
status=0
for ((i = 0; i < shards; ++i)); do
  if wait "${pids[$i]}" && grep -q '^\[  PASSED  \]' "$logs/$i.log"; then
    echo "$(basename "$binary") shard $((i + 1)) of $shards: $(grep '^\[==========\]' "$logs/$i.log" | tail -n 1)"
  else
    echo "$(basename "$binary") shard $((i + 1)) of $shards FAILED; its output:"
    cat "$logs/$i.log"
    status=1
  fi
done
exit $status

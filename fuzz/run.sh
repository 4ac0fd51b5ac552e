#!/usr/bin/env bash
# Runs every fuzz target for SECONDS_PER_TARGET (default 20, the CI run) on a throw-away
# copy of the committed corpus, one target at a time, and fails on the first crash.
#
#   fuzz/run.sh            # CI: 5 targets x 20 s
#   fuzz/run.sh 600        # a longer run: 10 min per target
#
# Needs the nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz --locked`).
# Targets are built once with debug assertions and overflow checks (the cargo-fuzz
# default) and without a sanitizer: the library forbids `unsafe`, so AddressSanitizer
# would only halve the speed. New inputs libFuzzer finds go to the copy and are thrown
# away; a crash leaves its input in fuzz/artifacts/<target>/ and the script exits 1.
set -euo pipefail

secs=${1:-20}
cd "$(dirname "$0")"
targets=(raw_reader time_parser elevator_toml model_file state_file)
flags=(-s none)

cargo +nightly fuzz build "${flags[@]}"

work=$(mktemp -d "${TMPDIR:-/tmp}/liftwatch-fuzz.XXXXXX")
trap 'rm -rf "$work"' EXIT

for t in "${targets[@]}"; do
    cp -r "corpus/$t" "$work/$t"
    echo "== $t: ${secs} s"
    # -rss_limit_mb: a leak or an unbounded allocation is a crash too.
    # -print_final_stats: the `stat::number_of_executed_units` line gives the count.
    cargo +nightly fuzz run "${flags[@]}" "$t" "$work/$t" -- \
        -max_total_time="$secs" -rss_limit_mb=2048 -print_final_stats=1 2>&1 |
        tee "$work/$t.log"
    grep -h 'stat::number_of_executed_units' "$work/$t.log" | sed "s/^/$t /"
done
echo "fuzz: every target ran ${secs} s without a crash"

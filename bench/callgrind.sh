#!/usr/bin/env bash
# Instruction counts per step of the real-time loops under callgrind: a noise-free
# regression check for a shared or 2-core CI machine (see bench/README.md).
#
#   bench/callgrind.sh                      # prints "<loop> <instructions per step>"
#   bench/callgrind.sh > new.txt
#   bench/callgrind.sh --compare base.txt   # also fails if a loop grew by more than 2 %
#
# Needs valgrind. Builds target/release/realtime_count (honours CARGO_TARGET_DIR).
set -euo pipefail

steps=${STEPS:-100000}
tolerance=${TOLERANCE:-0.02}
baseline=""
if [[ "${1:-}" == "--compare" ]]; then
    baseline=${2:?"--compare needs a baseline file"}
fi

cd "$(dirname "$0")/.."
cargo build --quiet --release -p zmp-bench --bin realtime_count
bin="${CARGO_TARGET_DIR:-target}/release/realtime_count"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

status=0
for loop in plant_all_effects plant_paper_nominal controller; do
    valgrind --tool=callgrind --callgrind-out-file="$out/$loop.cg" \
        --toggle-collect='*count_loop*' "$bin" "$loop" "$steps" >/dev/null 2>"$out/$loop.log"
    total=$(sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$out/$loop.log")
    per_step=$(awk -v t="$total" -v n="$steps" 'BEGIN { printf "%.1f", t / n }')
    echo "$loop $per_step"
    if [[ -n "$baseline" ]]; then
        base=$(awk -v l="$loop" '$1 == l { print $2 }' "$baseline")
        if [[ -n "$base" ]] && awk -v n="$per_step" -v b="$base" -v t="$tolerance" \
            'BEGIN { exit !(n > b * (1 + t)) }'; then
            echo "  regression: $loop $per_step instructions/step > $base * (1 + $tolerance)" >&2
            status=1
        fi
    fi
done
exit $status

#!/usr/bin/env bash
# The edit–test loop's times: a one-line change in a function's body, then the command a
# contributor runs, each timed three times (after one untimed change) and the median printed.
#
#   bash scripts/edit_loop_times.sh
#
# Two edits: in discovery (`ptsa-host-sim/src/discovery/fit.rs`, `fit`) and in the plant
# (`ptsa-sim/src/model/plant.rs`, `Plant::new`). The files are put back as they were, also
# on an error or Ctrl-C. Run it on an idle machine, after a test build (`cargo test --no-run`).
set -euo pipefail
cd "$(dirname "$0")/.."

backup=""
target=""
restore() { if [ -n "$backup" ]; then cp "$backup" "$target"; rm -f "$backup"; backup=""; fi; }
trap restore EXIT INT TERM

# time_edit FILE PATTERN LABEL CMD...: the median of three timed runs of CMD, each after a
# different `std::hint::black_box(N);` inserted after the first line matching PATTERN.
time_edit() {
  local file=$1 pattern=$2 label=$3; shift 3
  local line
  line=$(grep -n -m1 -- "$pattern" "$file" | cut -d: -f1)
  [ -n "$line" ] || { echo "$file: no line matches $pattern" >&2; exit 1; }
  target=$file
  backup=$(mktemp)
  cp "$file" "$backup"
  local times=()
  for n in 0 1 2 3; do
    cp "$backup" "$file"
    sed -i "${line}a\\    std::hint::black_box($n);" "$file"
    local s e
    s=$(date +%s.%N)
    "$@" >/dev/null 2>&1 || { echo "$label: \`$*\` failed" >&2; exit 1; }
    e=$(date +%s.%N)
    [ "$n" -gt 0 ] && times+=("$(echo "$e - $s" | bc)")
  done
  restore
  local median
  median=$(printf '%s\n' "${times[@]}" | sort -g | sed -n 2p)
  printf '%-58s median %6.2f s  (%s)\n' "$label" "$median" "${times[*]}"
}

fit='ptsa-host-sim/src/discovery/fit.rs'
plant='ptsa-sim/src/model/plant.rs'
time_edit "$fit" '^pub fn fit(' 'discovery edited: cargo check -p ptsa-host-sim --lib' \
  cargo check -p ptsa-host-sim --lib
time_edit "$fit" '^pub fn fit(' 'discovery edited: cargo test -p ptsa-host-sim --lib --no-run' \
  cargo test -p ptsa-host-sim --lib --no-run
time_edit "$fit" '^pub fn fit(' 'discovery edited: the binary ptsa (test profile)' \
  cargo build --profile test -p ptsa-host-sim --bin ptsa
time_edit "$plant" 'pub fn new(instr: &Instrument' 'plant edited: cargo check -p ptsa-host-sim --lib' \
  cargo check -p ptsa-host-sim --lib
time_edit "$plant" 'pub fn new(instr: &Instrument' 'plant edited: cargo test -p ptsa-sim --lib --no-run' \
  cargo test -p ptsa-sim --lib --no-run
time_edit "$plant" 'pub fn new(instr: &Instrument' 'plant edited: cargo test -p ptsa-host-sim --lib --no-run' \
  cargo test -p ptsa-host-sim --lib --no-run

#!/usr/bin/env bash
# Runs the fuzz targets of fuzz/ (docs/fuzzing.md) with libFuzzer, each for SECONDS.
#
#   scripts/fuzz.sh [SECONDS] [TARGET ...]      default: 60 s each, every target
#
# Built on the stable toolchain: libfuzzer-sys with LLVM's sanitizer-coverage passes (stable
# codegen flags, as `cargo fuzz --sanitizer none` passes them; no address sanitizer, which
# needs nightly). Each target starts from its seed corpus (fuzz/corpus/TARGET, committed)
# and the crash regressions (fuzz/regressions/TARGET), grows a working corpus in
# fuzz/work/TARGET (not committed) and writes a crashing, timing-out or memory-exhausting
# input to fuzz/artifacts/TARGET/. Ends with one line per target: executions, corpus size,
# and whether it found anything; exits 1 if any target did.
#
# Environment: PN_FUZZ_TARGET_DIR (default fuzz/target), PN_FUZZ_JOBS (cargo's -j,
# default 1), PN_FUZZ_RSS_MB (default 2048: more is an out-of-memory finding), PN_FUZZ_RUNS
# (stop a target after this many executions if that comes before SECONDS; default: no limit).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
all=(text_pde render_scene solve_scene set_override vol npy vdb exr race_point)
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${all[@]}")
target_dir="${PN_FUZZ_TARGET_DIR:-$PWD/fuzz/target}"
rss="${PN_FUZZ_RSS_MB:-2048}"
runs="${PN_FUZZ_RUNS:--1}"

export RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Ctarget-cpu=x86-64-v3"
# An explicit --target keeps the flags off build scripts and proc macros (host code).
host=$(rustc -vV | sed -n 's/^host: //p')
(cd fuzz && cargo build --locked --release --bins -j "${PN_FUZZ_JOBS:-1}" --target-dir "$target_dir" --target "$host")
bin_dir="$target_dir/$host/release"

found=0
summary=()
for t in "${targets[@]}"; do
  case "$t" in
    vol | npy | vdb | exr) max_len=65536 ;;
    *) max_len=16384 ;;
  esac
  work="fuzz/work/$t"
  art="fuzz/artifacts/$t"
  mkdir -p "$work" "$art" "fuzz/regressions/$t"
  log="fuzz/work/$t.log"
  echo "fuzz: $t for ${seconds} s"
  set +e
  start=$(date +%s)
  "$bin_dir/$t" "$work" "fuzz/corpus/$t" "fuzz/regressions/$t" \
    -max_total_time="$seconds" -runs="$runs" -max_len="$max_len" -timeout=10 -rss_limit_mb="$rss" \
    -artifact_prefix="$art/" -print_final_stats=1 >"$log" 2>&1
  rc=$?
  elapsed=$(($(date +%s) - start))
  set -e
  # (No final statistics when the target died of a signal libFuzzer cannot catch, such as
  # a stack overflow: then the log's last progress line counts.)
  execs=$({ grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" || grep -o '^#[0-9]*' "$log" || true; } | grep -o '[0-9]*$' | tail -1)
  units=$(ls "$work" | wc -l)
  if [ "$rc" -ne 0 ]; then
    found=1
    status="FOUND SOMETHING (exit $rc; see $log and $art)"
    [ "$rc" -ge 128 ] && status="$status: killed by signal $((rc - 128)), no input saved (a stack overflow?)"
    tail -40 "$log"
  else
    status="no crash, timeout or out-of-memory"
  fi
  summary+=("$t: ${execs:-?} executions in ${elapsed} s, working corpus $units inputs: $status")
done
echo "fuzz summary ($(date -u +%Y-%m-%d), $(nproc) cores):"
printf '  %s\n' "${summary[@]}"
exit "$found"

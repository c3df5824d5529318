#!/usr/bin/env bash
# Coverage-guided fuzzing of every reader and loader on stable Rust: builds
# the targets with libFuzzer's instrumentation (what `cargo fuzz` does with
# `--sanitizer none`), then runs each for SECONDS (default 30) from its
# committed corpus in fuzz/corpus/TARGET plus, where RATFIT_DATA is set,
# the real files of that folder. A finding (panic, non-finite value of an
# accepted input, more than 2 GB resident, an input taking over 10 s) stops
# the run with the input saved under fuzz/artifacts/TARGET.
#   fuzz/run.sh [SECONDS] [TARGET...]   (RATFIT_FUZZ_SEED=N for another
#   campaign than the reproducible default, seed 1)
set -euo pipefail
cd "$(dirname "$0")"
seconds="${1:-30}"
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(rgl text fit cdf scene)
fi
host="$(rustc -vV | sed -n 's/^host: //p')"
# --target keeps the instrumentation off build scripts and proc macros.
export RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing"
cargo build --release --target "$host" --bins
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for t in "${targets[@]}"; do
    corpus="$work/$t"
    mkdir -p "$corpus" "artifacts/$t"
    cp corpus/"$t"/* "$corpus"/ 2>/dev/null || true
    # Real files as seeds, read where they are (never copied into the
    # repository).
    if [ -n "${RATFIT_DATA:-}" ]; then
        case "$t" in
            rgl) cp "$RATFIT_DATA"/rgl/*.bsdf "$corpus"/ ;;
            text)
                for f in "$RATFIT_DATA"/cornell/*.brdf; do (printf '\x00'; head -c 60000 "$f") > "$corpus/cornell-$(basename "$f")"; done
                for f in "$RATFIT_DATA"/alta/*.alta "$RATFIT_DATA"/alta/*.dat; do (printf '\x01'; head -c 60000 "$f") > "$corpus/alta-$(basename "$f")"; done
                for f in "$RATFIT_DATA"/alta/rational-*.brdf; do (printf '\x02'; cat "$f") > "$corpus/rational-$(basename "$f")"; done
                ;;
        esac
    fi
    echo "fuzz: $t for ${seconds} s from $(ls "$corpus" | wc -l) seeds"
    "target/$host/release/$t" "$corpus" -max_total_time="$seconds" -timeout=10 \
        -rss_limit_mb=2048 -malloc_limit_mb=2048 -max_len=1048576 -seed="${RATFIT_FUZZ_SEED:-1}" \
        -artifact_prefix="artifacts/$t/" -print_final_stats=1 > "$work/$t.log" 2>&1 || {
        tail -n 60 "$work/$t.log"
        echo "fuzz: $t found an input that fails; it is in fuzz/artifacts/$t" >&2
        exit 1
    }
    grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb|Done [0-9]+ runs" "$work/$t.log" || true
done

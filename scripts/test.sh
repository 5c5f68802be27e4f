#!/usr/bin/env bash
# The one test command (README): formatting, lints, every test of the workspace.
# CI (.ci/run) runs exactly this after installing the toolchain.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check"
cargo fmt --all -- --check

echo "== cargo clippy (warnings denied)"
cargo clippy --workspace --all-targets --locked -- -D warnings

echo "== cargo test"
cargo test --workspace --locked

echo "== benchmarks, smoke run (fast tier)"
cargo bench --workspace --locked -- --test

#!/bin/sh
# Builds the linterpd .deb: the release binary, then the shell completions and man pages it
# generates from its own clap definitions (into target/release/package/, where Cargo.toml's
# [package.metadata.deb] assets expect them), then `cargo deb --no-build`.
#
#   cargo install cargo-deb --locked     # once
#   deploy/package.sh                    # -> target/debian/linterpd_<version>-1_<arch>.deb
#
# Honours CARGO_TARGET_DIR like cargo and cargo-deb do. Extra arguments go to cargo deb.
set -eu
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
cargo build --release --locked
bin="$target/release/linterpd"
out="$target/release/package"
rm -rf "$out"
mkdir -p "$out/completions" "$out/man"
"$bin" completions bash > "$out/completions/linterpd.bash"
"$bin" completions zsh > "$out/completions/_linterpd"
"$bin" completions fish > "$out/completions/linterpd.fish"
"$bin" man --dir "$out/man"
gzip -9n "$out"/man/*.1
cargo deb --no-build --strip --locked "$@"

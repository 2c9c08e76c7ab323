#!/bin/sh
# Builds the linterpd .deb: the release binary, then the shell completions and man pages it
# generates from its own clap definitions (into target/release/package/, where Cargo.toml's
# [package.metadata.deb] assets expect them), then `cargo deb --no-build`.
#
#   cargo install cargo-deb --locked     # once (3.3 or newer)
#   deploy/package.sh                    # -> target/debian/linterpd_<version>-1_<arch>.deb
#
# Honours CARGO_TARGET_DIR like cargo and cargo-deb do. Extra arguments go to cargo deb.
set -eu
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"

# cargo-deb 3.3 is the first to put units in usr/lib/systemd/system/ and to give the unit
# installed there (Cargo.toml's assets) the systemd-units handling: stopped on removal, never
# restarted by an upgrade. An older one would build a package without it: refuse.
have=$(cargo deb --version 2>/dev/null | sed -n 's/[^0-9]*\([0-9][0-9]*\)\.\([0-9][0-9]*\).*/\1 \2/p' | head -n 1)
if [ -z "$have" ]; then
    echo "deploy/package.sh: cargo-deb is not installed: cargo install cargo-deb --locked (3.3 or newer)" >&2
    exit 2
fi
set -- $have "$@"
major=$1 minor=$2
shift 2
if [ "$major" -lt 3 ] || { [ "$major" -eq 3 ] && [ "$minor" -lt 3 ]; }; then
    echo "deploy/package.sh: cargo-deb $major.$minor is older than 3.3, whose systemd-units handling the package needs: cargo install cargo-deb --locked --force" >&2
    exit 2
fi
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
# cargo-deb warns "No usable systemd units found for `linterpd` in `deploy/debian/`": expected,
# the unit is one of Cargo.toml's assets, and cargo-deb handles it there (check with `dpkg-deb
# -e target/debian/linterpd_*.deb x && cat x/prerm`: a stop on remove, nothing on upgrade).
cargo deb --no-build --strip --locked "$@"

#!/usr/bin/env bash
# One-time machine set-up shared by ./dev and .ci/run: Debian packages and the shared cargo
# target directory. Idempotent and quick when everything is present.
set -euo pipefail

# Runtime: Vulkan loader + Mesa (llvmpipe software rendering when there is no GPU).
# Windowed runs load X11/xkbcommon at run time. Building needs nothing beyond the toolchain:
# the trimmed Bevy features use no audio, gamepad or udev crates.
# gcc + libc6-dev: the linker driver `cc` and crates that compile C in build scripts.
# python3-openvdb: the export tests open the written volumes with OpenVDB itself
# (tools/check_vdb.py; 22 MB download).
PKGS=(gcc libc6-dev libvulkan1 mesa-vulkan-drivers libx11-6 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0
    python3-openvdb)
missing=()
for p in "${PKGS[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if ((${#missing[@]})); then
    echo "setup: installing Debian packages: ${missing[*]}"
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
if ! command -v cargo >/dev/null 2>&1; then
    echo "setup: cargo not found: install Rust 1.95 (rustup) first" >&2
    exit 1
fi
rust_minor=$(rustc --version | sed -E 's/^rustc 1\.([0-9]+).*/\1/')
if [ "${rust_minor:-0}" -lt 95 ]; then
    echo "setup: Rust 1.95 or newer is required (found $(rustc --version))" >&2
    exit 1
fi
for c in clippy rustfmt; do
    if ! cargo "${c/rustfmt/fmt}" --version >/dev/null 2>&1 && command -v rustup >/dev/null; then
        rustup component add "$c"
    fi
done

#!/usr/bin/env bash
# Runs every test of epivox on a fresh Debian/Ubuntu machine.
#
# 1. Installs, only when missing, what the tests need: the Mesa software Vulkan driver
#    (lavapipe, so the GPU tests run without a GPU) and Xvfb (a virtual X display).
# 2. Starts Xvfb (when DISPLAY is unset) for the editor window test.
# 3. Runs `cargo test --locked --all-targets` with WAYLAND_DISPLAY unset (and NODEVICE_SELECT=1
#    where XDG_RUNTIME_DIR is unset: no spurious Wayland errors in the log).
#
# Works from any directory; exits non-zero on the first failure.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

say() { printf '\n==> %s\n' "$*"; }

# ---------------------------------------------------------------- system packages
packages=(mesa-vulkan-drivers libvulkan1 xvfb xauth)

say "Checking system packages: ${packages[*]}"
if ! command -v dpkg >/dev/null 2>&1; then
    echo "    no dpkg (not Debian/Ubuntu): make sure the equivalents are installed yourself"
else
    missing=()
    for p in "${packages[@]}"; do
        if dpkg -s "$p" >/dev/null 2>&1; then
            echo "    $p: installed"
        else
            echo "    $p: missing"
            missing+=("$p")
        fi
    done

    if ((${#missing[@]} > 0)); then
        sudo=""
        if [[ $(id -u) -ne 0 ]]; then
            if command -v sudo >/dev/null 2>&1; then
                sudo="sudo"
            else
                echo "error: must install ${missing[*]}, but this is not root and there is no sudo" >&2
                exit 1
            fi
        fi
        say "Installing ${missing[*]} with apt-get"
        $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
        $sudo env DEBIAN_FRONTEND=noninteractive \
            apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
        echo "    installed"
    else
        echo "    nothing to install"
    fi
fi

# ---------------------------------------------------------------- Vulkan drivers
say "Vulkan drivers (ICD files in /usr/share/vulkan/icd.d)"
shopt -s nullglob
icds=(/usr/share/vulkan/icd.d/*.json)
shopt -u nullglob
if ((${#icds[@]} > 0)); then
    printf '    %s\n' "${icds[@]}"
else
    echo "    none found: GPU tests will have no Vulkan adapter"
fi

# ---------------------------------------------------------------- display for the editor test
# tests/editor_window.rs opens the real editor window; give it a virtual X display when there is
# none (the test skips, saying so, when DISPLAY stays unset).
unset WAYLAND_DISPLAY
# Without XDG_RUNTIME_DIR, Mesa's device-select layer makes libwayland print "error:
# XDG_RUNTIME_DIR is invalid" for every Vulkan instance a test makes; the epivox binary turns
# the layer off itself there (src/main.rs), the test processes need it said here.
if [[ -z "${XDG_RUNTIME_DIR:-}" ]]; then
    export NODEVICE_SELECT="${NODEVICE_SELECT:-1}"
fi
if [[ -z "${DISPLAY:-}" ]] && command -v Xvfb >/dev/null 2>&1; then
    display=":99"
    # Another server may hold :99 already (a previous run): pick the first free number.
    for n in 99 98 97 96 95; do
        if [[ ! -e "/tmp/.X11-unix/X$n" && ! -e "/tmp/.X$n-lock" ]]; then
            display=":$n"
            break
        fi
    done
    say "Starting Xvfb $display for the editor window test"
    Xvfb "$display" -screen 0 1600x1000x24 -nolisten tcp >/dev/null 2>&1 &
    xvfb_pid=$!
    trap 'kill "$xvfb_pid" 2>/dev/null || true' EXIT
    for _ in $(seq 50); do
        [[ -e "/tmp/.X11-unix/X${display#:}" ]] && break
        sleep 0.1
    done
    export DISPLAY="$display"
fi
echo "    DISPLAY=${DISPLAY:-unset}"

# ---------------------------------------------------------------- tests

if ! command -v cargo >/dev/null 2>&1; then
    echo "error: cargo not found; install Rust (https://rustup.rs) and run this again" >&2
    exit 1
fi
say "cargo test --locked --all-targets"
cargo test --locked --all-targets

say "All tests passed"

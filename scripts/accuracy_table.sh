#!/usr/bin/env bash
# Renders each scene with VSV at its default grid and with the exact reference, compares their
# scattered light and writes a side-by-side picture per scene (reference | VSV | difference x4).
#
#   scripts/accuracy_table.sh OUT_DIR [SIZE] [EPIVOX]
#
# SIZE defaults to 512 (square images); EPIVOX to target/release/epivox (build it first with
# `cargo build --release`). References are kept in OUT_DIR and reused when they exist: delete them
# after changing the reference renderer or a scene. Prints one line per scene: the relative RMSE
# of the scattered light and VSV's GPU time.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

out=${1:?usage: scripts/accuracy_table.sh OUT_DIR [SIZE] [EPIVOX]}
size=${2:-512}
epivox=${3:-target/release/epivox}
mkdir -p "$out"

scenes=(
    "builtin:"
    "cornell:../shared/scenes/cornell_box"
    "classroom:../shared/scenes/japanese_classroom"
    "bunny:../shared/scenes/stanford_bunny/bun_zipper.ply"
)
printf '%-10s %8s %10s  %s\n' scene size "VSV ms" "scattered light against the reference"
for entry in "${scenes[@]}"; do
    name=${entry%%:*}
    path=${entry#*:}
    args=()
    [[ -n $path ]] && args+=("$path")
    ref="$out/${name}_${size}_reference.exr"
    if [[ ! -f $ref ]]; then
        "$epivox" render "${args[@]}" --size "${size}x${size}" --method reference \
            --out "$out/${name}_${size}_reference.png" --scatter-exr "$ref" --json >/dev/null 2>&1
    fi
    vsv="$out/${name}_${size}_vsv.exr"
    ms=$("$epivox" render "${args[@]}" --size "${size}x${size}" --out "$out/${name}_${size}_vsv.png" \
        --scatter-exr "$vsv" --json 2>/dev/null | python3 -c 'import json,sys; print(round(json.load(sys.stdin)["total_ms"]))')
    stats=$("$epivox" compare "$vsv" "$ref" --diff "$out/${name}_${size}_compare.png")
    printf '%-10s %8s %10s  %s\n' "$name" "$size" "$ms" "${stats#*: }"
done

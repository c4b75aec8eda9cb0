#!/usr/bin/env bash
# Renders each scene with VSV at its default grid and with the exact reference, compares their
# scattered light and writes a side-by-side picture per scene (reference | VSV | difference x4).
#
#   scripts/accuracy_table.sh OUT_DIR [SIZE] [EPIVOX]
#
# SIZE defaults to 512 (square images); EPIVOX to target/release/epivox (build it first with
# `cargo build --release`). References are kept in OUT_DIR and reused when they exist: delete them
# after changing the reference renderer or a scene. Prints one line per scene: VSV's GPU time, the
# relative RMSE of the scattered light against the exact image, and against the reference
# integrated along VSV's own view segments (`--view-ends`: the rasterizer's surfaces instead of
# the reference's first hits) with the number of pixels whose primary visibility differs. The
# second figure is the volumetric error alone; a pixel centre within the rasterizer's sub-pixel
# precision of a silhouette edge can land on either side of it (docs/accuracy.md).
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
printf '%-10s %8s %10s  %-50s %s\n' scene size "VSV ms" "scattered light against the reference" \
    "along VSV's view segments (pixels whose first surface differs)"
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
    depth="$out/${name}_${size}_vsv_depth.exr"
    ms=$("$epivox" render "${args[@]}" --size "${size}x${size}" --out "$out/${name}_${size}_vsv.png" \
        --scatter-exr "$vsv" --depth-exr "$depth" --json 2>/dev/null |
        python3 -c 'import json,sys; print(round(json.load(sys.stdin)["total_ms"]))')
    stats=$("$epivox" compare "$vsv" "$ref" --diff "$out/${name}_${size}_compare.png")
    # The reference along VSV's segments, again only when VSV's surfaces moved.
    seg="$out/${name}_${size}_reference_segments.exr"
    ends="$out/${name}_${size}_reference_segments_ends.exr"
    differing="$out/${name}_${size}_reference_segments_differing.txt"
    if [[ ! -f $seg || ! -f $differing ]] || ! cmp -s "$depth" "$ends"; then
        "$epivox" render "${args[@]}" --size "${size}x${size}" --method reference --view-ends "$depth" \
            --out "$out/${name}_${size}_reference_segments.png" --scatter-exr "$seg" --json 2>/dev/null |
            python3 -c 'import json,sys; print(json.load(sys.stdin)["view_ends_differing"])' >"$differing"
        cp "$depth" "$ends"
    fi
    seg_stats=$("$epivox" compare "$vsv" "$seg")
    seg_rmse=${seg_stats#*rel RMSE }
    printf '%-10s %8s %10s  %-50s %s (%s)\n' "$name" "$size" "$ms" "${stats#*: }" "${seg_rmse%% |*}" "$(cat "$differing")"
done

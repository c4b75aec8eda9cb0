#!/usr/bin/env bash
# The benches docs/results.md records for a hardware GPU, in one run that stops by a deadline:
# the classroom at 512x512 (the issue's target: VSV's default grid against the march's sweep,
# three interleaved rounds), at 1024x1024 (which holds the paper's 1024x1024x256 grid), the
# time-against-triangles sweep, and the bunny at 1024x1024. Each bench writes its report.md,
# results.csv and plots into a folder of OUT_DIR; `render --json` adds the adapter and one frame's
# per-pass GPU times at 1024x1024 for the default grid and the paper's (each also with
# `--scan threads`, the CPU adapters' Scan, and the 512x512 bench once more with it), the
# bunny's scattered light as EXR, and Surface's time with its fragment shader cut down. The
# 512x512 classroom bench also measures grids larger than llvmpipe's 128 MiB binding allows
# (`--grid`): on the software driver every 100 MB grid shape stops near 1% (docs/results.md,
# "Where the classroom's remaining error lies"), and a GPU can show whether more bits get VSV
# below the 1024-step march's 0.76% (the chase then finds a finer march to compare with); with
# 2048x384x1280 (on llvmpipe as fast as the default and 10% more accurate, session 26; with grid
# shadows more accurate than the default map frame on both errors, session 27: the candidate new
# default once its GPU time is known) and
# 2048x512x2048 (more bins, which bought the most so far: 2048x512x1536 measured 0.780%). The
# renders, the 512x512 classroom bench, the bunny and the scaling sweep run once more with VSV's
# surface shadows from the shadow volume (`--surface-shadows grid`: no shadow map in its frames),
# and the 512x512 classroom bench with the map's surface shadows (`--surface-shadows map`; the
# default under a sun is exact since session 45).
#
#   scripts/gpu_bench.sh OUT_DIR [EPIVOX] [CACHE_DIR] [SECONDS]
#
# EPIVOX defaults to target/release/epivox, CACHE_DIR (the references; a 1024x1024 classroom
# reference takes minutes of CPU) to OUT_DIR/cache, SECONDS (the whole run's budget) to 480. A bench
# that would run past the deadline is stopped and the next is skipped; what finished is kept.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

out=${1:?usage: scripts/gpu_bench.sh OUT_DIR [EPIVOX] [CACHE_DIR] [SECONDS]}
epivox=${2:-target/release/epivox}
cache=${3:-$out/cache}
deadline=$(($(date +%s) + ${4:-480}))
classroom=../shared/scenes/japanese_classroom
bunny=../shared/scenes/stanford_bunny/bun_zipper.ply
mkdir -p "$out"

# Runs "$@" with what is left of the budget, logging to OUT_DIR/NAME.log; prints the wall time.
step() {
    local name=$1
    shift
    local left=$((deadline - $(date +%s)))
    if ((left < 10)); then
        echo "$name: skipped, the budget is spent"
        return
    fi
    local t0=$SECONDS
    timeout "$left" "$@" >"$out/$name.log" 2>&1
    echo "$name: exit status $? after $((SECONDS - t0)) s"
}

command -v nvidia-smi >/dev/null && nvidia-smi >"$out/nvidia-smi.txt" 2>&1
step render_default "$epivox" render "$classroom" --size 1024x1024 --json --out "$out/classroom_1024.png"
step render_paper "$epivox" render "$classroom" --size 1024x1024 --grid 1024x1024x256 --json \
    --out "$out/classroom_1024_grid1024x1024x256.png"
# The same two frames with Scan's thread per column (`--scan threads`; a GPU's default is a
# workgroup per plane), to keep the two measured side by side.
step render_default_threads "$epivox" render "$classroom" --size 1024x1024 --json --scan threads \
    --out "$out/classroom_1024_threads.png"
step render_paper_threads "$epivox" render "$classroom" --size 1024x1024 --grid 1024x1024x256 --json \
    --scan threads --out "$out/classroom_1024_grid1024x1024x256_threads.png"
# The bunny's scattered light, to compare with its reference pixel by pixel (its worst pixel is the
# light's own: 246 in the reference, where 1 / sin(gamma) magnifies any error of sin).
step render_bunny "$epivox" render "$bunny" --size 1024x1024 --json --out "$out/bunny_1024.png" \
    --scatter-exr "$out/bunny_1024_scatter.exr"
# Where Surface's time goes on a GPU that rasterizes on a few of its units (the H200: 1.21 ms at
# 1024x1024, against 0.029 ms for Composite, a compute pass over the same pixels): the same frame
# with Surface's fragment shader cut down and its two outputs kept, through EPIVOX_SHADER_DIR
# (the images are wrong; only Surface's time counts). "flat": constants; "no_normal": albedo and
# distance, without the derivatives and normalizations. Near "flat", the fragment work is the
# cost, and a visibility buffer resolved in compute would pay; near the default, rasterizing is.
# (The folder holds surface.wgsl alone: every other shader comes from the binary's own copies.)
surface_variant() {
    local dir=$out/shaders_$1
    mkdir -p "$dir" && sed '/^@fragment/,$d' shaders/surface.wgsl >"$dir/surface.wgsl"
    cat >>"$dir/surface.wgsl"
}
surface_variant flat <<'WGSL'
@fragment
fn fs_main(i: VsOut) -> FsOut {
    return FsOut(vec4f(0.5), vec4f(1.0, 0.0, 0.0, 0.0));
}
WGSL
surface_variant no_normal <<'WGSL'
@fragment
fn fs_main(i: VsOut) -> FsOut {
    f = frame_in;
    return FsOut(vec4f(i.albedo, 0.5), vec4f(length(f.eye.xyz - i.world), 0.0, 0.0, 0.0));
}
WGSL
for v in flat no_normal; do
    EPIVOX_SHADER_DIR=$out/shaders_$v step "render_surface_$v" "$epivox" render "$classroom" \
        --size 1024x1024 --json --out "$out/surface_$v.png"
done
# VSV with its surface shadows from the shadow volume (`--surface-shadows grid`): its frames draw
# no shadow map, which on the H200 was 1.4 of the classroom's 2.3 ms at 512x512 (session 24's run).
step render_default_grid_shadows "$epivox" render "$classroom" --size 1024x1024 --json \
    --surface-shadows grid --out "$out/classroom_1024_grid_shadows.png"
step render_paper_grid_shadows "$epivox" render "$classroom" --size 1024x1024 --grid 1024x1024x256 --json \
    --surface-shadows grid --out "$out/classroom_1024_grid1024x1024x256_grid_shadows.png"
# VSV with the map's surface shadows (`--surface-shadows map`): the default under the sun is exact
# since session 45 (compute only, no map after the first frame; on llvmpipe a frame 2-5% longer than the map's,
# on a GPU not yet measured), so this is the comparison for it.
step classroom512_map_shadows "$epivox" bench "$classroom" --size 512x512 --frames 5 --rounds 3 --no-scaling \
    --surface-shadows map --cache-dir "$cache" --out "$out/classroom512_map_shadows"
step classroom512_grid_shadows "$epivox" bench "$classroom" --size 512x512 --frames 5 --rounds 3 --no-scaling \
    --surface-shadows grid --grid 2048x512x1536 --grid 2048x384x1280 --grid 2048x512x2048 \
    --cache-dir "$cache" --out "$out/classroom512_grid_shadows"
step classroom512 "$epivox" bench "$classroom" --size 512x512 --frames 5 --rounds 3 --no-scaling \
    --grid 4096x512x768 --grid 2048x1024x768 --grid 2048x512x1536 --grid 4096x1024x1024 \
    --grid 2048x384x1280 --grid 2048x512x2048 --cache-dir "$cache" --out "$out/classroom512"
step classroom512_threads "$epivox" bench "$classroom" --size 512x512 --frames 5 --no-scaling --scan threads \
    --cache-dir "$cache" --out "$out/classroom512_threads"
[[ -f $bunny ]] && step bunny "$epivox" bench "$bunny" --size 1024x1024 --frames 3 --no-scaling \
    --cache-dir "$cache" --out "$out/bunny"
[[ -f $bunny ]] && step bunny_grid_shadows "$epivox" bench "$bunny" --size 1024x1024 --frames 3 --no-scaling \
    --surface-shadows grid --cache-dir "$cache" --out "$out/bunny_grid_shadows"
step classroom1024 "$epivox" bench "$classroom" --size 1024x1024 --frames 5 --rounds 3 --no-scaling \
    --cache-dir "$cache" --out "$out/classroom1024"
step scaling "$epivox" bench "$classroom" --size 512x512 --frames 3 --cache-dir "$cache" \
    --out "$out/scaling"
step scaling_grid_shadows "$epivox" bench "$classroom" --size 512x512 --frames 3 --cache-dir "$cache" \
    --surface-shadows grid --out "$out/scaling_grid_shadows"

# The lines a reader wants first: the adapter and each bench's ratio.
grep -h '"adapter"' "$out"/render_*.log 2>/dev/null | head -1
for r in "$out"/*/report.md; do
    [[ -f $r ]] && echo "$r" && grep -h "^| vsv |" "$r" | head -20
done

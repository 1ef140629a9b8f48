#!/usr/bin/env bash
# Caster culling on city street views that its constants were not tuned on
# (config/bench/streets/*.json: other seeds, city sizes, sun directions, map and output
# sizes), and a bird's-eye view: `frustum` against `receiver-mask`, for one or two engine
# builds side by side in one run (alternating, so that a noisy machine treats them alike).
#
#   tests/benchmarks/culling_street_views.sh NEW_PENUMBRA [OLD_PENUMBRA] [CONFIG...]
#
# Per view and build, medians of `render --frames 9 --warmup 2`:
#   depth      the technique's shadow-map pass (GPU ms): frustum's, then receiver-mask's
#   masks      receiver masks ms, cull: caster culling ms, queries: occlusion queries
#   shadow     masks + cull + receiver-mask's depth pass: the shadow work
#   cull/depth caster culling over the frustum depth pass it replaces (goal <= 1/3)
#   speed-up   frustum's depth pass over receiver-mask's shadow work (goal >= 3 at street
#              level; a bird's-eye view falls back to its frustum: goal <= 5 % slower)
#   frames     frame wall clock, frustum over receiver-mask
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
new=${1:?usage: $0 NEW_PENUMBRA [OLD_PENUMBRA] [CONFIG...]}
shift
builds=("$new")
if [[ $# -gt 0 && "$1" != *.json ]]; then
    builds+=("$1")
    shift
fi
configs=("$@")
if [[ ${#configs[@]} -eq 0 ]]; then configs=("$root"/config/bench/streets/*.json); fi
frameCount=${FRAMES:-9}
warmup=${WARMUP:-2}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# figure FILE LABEL: the number after LABEL in a render's output (the GPU column for passes).
figure() { awk -v label="$2" 'index($0, label) { for (i = 1; i <= NF; ++i) if ($i ~ /^[0-9.]+$/) { print $i; exit } }' "$1"; }

printf '%-12s %-5s %9s %9s %9s %9s %8s %9s %10s %9s %7s\n' view build frustum depth masks cull queries shadow cull/depth speed-up frames
for config in "${configs[@]}"; do
    view=$(basename "$config" .json)
    for mode in frustum receiver-mask; do
        for b in "${!builds[@]}"; do
            "${builds[$b]}" render "$config" --culling "$mode" --stats --timings --frames "$frameCount" --warmup "$warmup" \
                -o "$out/$view.$b.$mode.png" >"$out/$view.$b.$mode.txt" 2>&1
        done
    done
    for b in "${!builds[@]}"; do
        name=$([[ $b -eq 0 ]] && echo new || echo old)
        f="$out/$view.$b.frustum.txt" m="$out/$view.$b.receiver-mask.txt"
        frustum=$(figure "$f" shadow_map)
        depth=$(figure "$m" shadow_map)
        masks=$(figure "$m" "receiver masks ms")
        cull=$(figure "$m" "caster culling ms")
        queries=$(figure "$m" "occlusion queries issued")
        frustumFrame=$(figure "$f" "frame wall clock") maskFrame=$(figure "$m" "frame wall clock")
        awk -v v="$view" -v n="$name" -v f="$frustum" -v d="$depth" -v m="$masks" -v c="$cull" -v q="$queries" \
            -v ff="$frustumFrame" -v mf="$maskFrame" 'BEGIN {
            s = m + c + d
            printf "%-12s %-5s %9.1f %9.1f %9.1f %9.1f %8d %9.1f %10.2f %9.2f %7.2f\n", v, n, f, d, m, c, q, s, c / f, f / s, ff / mf }'
    done
done

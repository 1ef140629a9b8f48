#!/usr/bin/env bash
# Builds the libFuzzer targets (the `fuzz` preset: Clang, ASan + UBSan), gathers their
# seed corpora and runs them (docs/fuzzing.md).
#
#   tests/fuzz/run.sh [--seconds N | --runs N] [--jobs N] [target...]
#
# targets: config, gltf, plugin_file (default: all three, run side by side). Each runs
# for N seconds (default 60) or N executions, from its seeds plus what earlier runs kept
# in build/fuzz/corpus/<target>. A finding (crash, sanitizer report, uncaught
# exception, timeout, out of memory) is written to build/fuzz/findings/ and makes the
# script exit 1; the summary gives each target's executions and coverage.
#
# Seeds: config/ and tests/data/configs (config); tests/data/gltf, assets/, Debian's
# assimp-testmodels glTF 2.0 files and small scenes of every generator written with the
# CLI of the release build when there is one (gltf); a tiny shared object built here,
# damaged copies of it (tests/fuzz/damage_elf.py) and pieces of the build's plugins
# (plugin_file).
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$PWD

limit=(-max_total_time=60)
jobs=""
targets=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --seconds) limit=(-max_total_time="$2"); shift 2 ;;
    --runs) limit=(-runs="$2"); shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    config|gltf|plugin_file) targets+=("$1"); shift ;;
    *) echo "usage: $0 [--seconds N | --runs N] [--jobs N] [config|gltf|plugin_file]..." >&2; exit 2 ;;
  esac
done
[[ ${#targets[@]} -gt 0 ]] || targets=(config gltf plugin_file)

cmake --preset fuzz >/dev/null
cmake --build --preset fuzz
build=$root/build/fuzz
seeds=$build/seeds
rm -rf "$seeds"
mkdir -p "$seeds"/{config,gltf,plugin_file} "$build/findings"

# config: every shipped and test config, named by its path so that none hides another.
while IFS= read -r f; do
  cp "$f" "$seeds/config/$(echo "${f#./}" | tr / _)"
done < <(find config tests/data/configs -name '*.json')

# gltf: small files only (the target's -max_len is 16 KiB).
while IFS= read -r f; do
  cp "$f" "$seeds/gltf/$(echo "$f" | tr / _ | sed 's/^_//')"
done < <(find tests/data/gltf assets /usr/share/assimp/models/glTF2 \( -name '*.gltf' -o -name '*.glb' \) -size -16k 2>/dev/null)
cli=$root/build/ci/apps/penumbra/penumbra
[[ -x $cli ]] || cli=$root/build/release/apps/penumbra/penumbra
if [[ -x $cli ]]; then
  gen() { "$cli" generate "$1" -o "$seeds/gltf/generated-$1.glb" "${@:2}" 2>/dev/null; }
  gen box-grid --set columns=2 --set rows=2 --set sphere_segments=8
  gen penumbra
  gen fence --set holes_x=2 --set holes_y=2
  gen box-field --set boxes=4
  gen hair --set strands=2 --set segments=2 --set head_radius=0.1
  gen city --set blocks=1 --set lots_per_side=1 --set car_density=0 --set tree_chance=0
  # A .gltf with its buffer embedded is another parser path than a .glb.
  "$cli" generate penumbra -o "$seeds/gltf/generated-penumbra.gltf" 2>/dev/null
else
  echo "fuzz: no release build of the CLI: no generated scenes among the glTF seeds" >&2
fi

# plugin_file: a tiny shared object (the check's whole path: a constructor and a
# destructor give it initialiser and finaliser arrays and their relocations), its
# truncations, one damaged copy per check of the header and the dynamic section
# (damage_elf.py: a foreign machine, byte order and class; tables, arrays and sizes
# pointing outside the file) and the first pages of the build's plugins.
cat > "$build/tiny.cpp" <<'CPP'
static volatile int state;
extern "C" int penumbra_plugin_entry() { return state; }
__attribute__((constructor)) static void loaded() { state = 1; }
__attribute__((destructor)) static void unloaded() { state = 2; }
CPP
c++ -shared -fPIC -nostdlib -O1 -s -Wl,-z,max-page-size=4096 -Wl,-z,noseparate-code \
  -o "$seeds/plugin_file/tiny.so" "$build/tiny.cpp"
head -c 64 "$seeds/plugin_file/tiny.so" > "$seeds/plugin_file/tiny-header"
head -c 1024 "$seeds/plugin_file/tiny.so" > "$seeds/plugin_file/tiny-1k"
python3 "$root/tests/fuzz/damage_elf.py" "$seeds/plugin_file/tiny.so" "$seeds/plugin_file"
for so in "$root"/build/ci/plugins/penumbra-*.so; do
  [[ -f $so ]] && head -c 8192 "$so" > "$seeds/plugin_file/$(basename "$so").8k"
done

declare -A maxlen=([config]=8192 [gltf]=16384 [plugin_file]=16384)
declare -A dict=([config]=-dict=$root/tests/fuzz/config.dict [gltf]=-dict=$root/tests/fuzz/gltf.dict [plugin_file]=)
pids=()
for t in "${targets[@]}"; do
  mkdir -p "$build/corpus/$t"
  args=("${limit[@]}" -max_len="${maxlen[$t]}" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1
        -artifact_prefix="$build/findings/$t-" ${dict[$t]})
  [[ -n $jobs ]] && args+=(-fork="$jobs" -ignore_crashes=0)
  echo "fuzz: $t: $build/tests/fuzz/penumbra_fuzz_$t ${args[*]} corpus/$t seeds/$t"
  (cd "$build" && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
     "tests/fuzz/penumbra_fuzz_$t" "${args[@]}" "corpus/$t" "seeds/$t" > "$build/$t.log" 2>&1) &
  pids+=($!)
done

status=0
for i in "${!targets[@]}"; do
  t=${targets[$i]}
  rc=0
  wait "${pids[$i]}" || rc=$?
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$build/$t.log" | grep -o '[0-9]*$' | tail -1 || true)
  cov=$(grep -o 'cov: [0-9]*' "$build/$t.log" | tail -1 || true)
  if [[ $rc -eq 0 ]]; then
    echo "fuzz: $t: no finding in ${execs:-?} executions (${cov:-cov: ?}); log: build/fuzz/$t.log"
  else
    status=1
    echo "fuzz: $t: FINDING (exit $rc) after ${execs:-?} executions; log: build/fuzz/$t.log"
    grep -E 'penumbra fuzz:|Assertion|ERROR|SUMMARY|Test unit written|terminate|what\(\)' "$build/$t.log" | head -20
  fi
done
exit $status

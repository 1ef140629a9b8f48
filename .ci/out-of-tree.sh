#!/usr/bin/env bash
# The plugin SDK as a plugin developer meets it (docs/plugins.md): install a built Penumbra
# into a temporary prefix, build plugins/example as a project of its own against that
# prefix (find_package(Penumbra) + penumbra_add_plugin), install it, and check that the
# installed penumbra runs from its prefix (its library, shaders and plugins, never the
# build tree's) and loads the plugin.
#
#   .ci/out-of-tree.sh [BUILD_DIR]     (default: build/release; CTest passes its own)
#
# Reuses BUILD_DIR as it is (nothing is rebuilt there); everything else happens in a
# temporary folder that is removed afterwards. Exit status 0 when every check passes.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-$root/build/release}" && pwd)"
work="$(mktemp -d "${TMPDIR:-/tmp}/penumbra-sdk.XXXXXX")"
trap 'rm -rf "$work"' EXIT
# The plugin scan cache (docs/plugins.md) of these runs stays in the temporary folder.
export XDG_CACHE_HOME="$work/cache"
prefix="$work/prefix"
example="$work/example-build"

fail() { echo "out-of-tree: FAILED: $*" >&2; exit 1; }
step() { echo "out-of-tree: $*"; }
cache_value() { sed -n "s/^$1:[A-Z]*=//p" "$build/CMakeCache.txt"; }

step "install $build into $prefix"
cmake --install "$build" --prefix "$prefix" >"$work/install.log" || { cat "$work/install.log"; fail "cmake --install"; }
for f in bin/penumbra libexec/penumbra/penumbra-plugin-scanner lib/libpenumbra_engine.so include/penumbra/plugin/Plugin.h \
         share/penumbra/shaders/common/visibility.glsl lib/cmake/Penumbra/PenumbraConfig.cmake \
         lib/cmake/Penumbra/PenumbraConfigVersion.cmake lib/cmake/Penumbra/PenumbraTargets.cmake \
         lib/cmake/Penumbra/PenumbraPlugin.cmake lib/penumbra/plugins/penumbra-example.so \
         lib/penumbra/plugins/example/visibility.comp; do
  [[ -e "$prefix/$f" ]] || fail "the install lacks $f"
done
# The package must not point back into the source or build tree it came from.
if grep -rlF -e "$root" -e "$build" "$prefix/lib/cmake/Penumbra"; then fail "the CMake package names the build machine's tree"; fi

# An installed engine searches its own plugins, <prefix>/lib/penumbra/plugins, and never
# the build tree's plugins/, which still exists here and declares the same names
# (plugin/PluginRegistry.h): every plugin loads, once, from the prefix.
step "the installed penumbra lists the installed plugins, from $prefix"
unset PENUMBRA_SHADER_DIR PENUMBRA_PLUGIN_PATH
"$prefix/bin/penumbra" plugins --strict >"$work/plugins.txt" 2>&1 \
  || { cat "$work/plugins.txt"; fail "the installed penumbra plugins --strict exits non-zero"; }
if grep -q "duplicate-name" "$work/plugins.txt"; then cat "$work/plugins.txt"; fail "the installed penumbra reports duplicate-name"; fi
"$prefix/bin/penumbra" plugins --json >"$work/installed-plugins.json" 2>"$work/plugins.log" \
  || { cat "$work/plugins.log"; fail "penumbra plugins --json (installed)"; }
python3 - "$work/installed-plugins.json" "$prefix/lib/penumbra/plugins" <<'PY' || fail "the installed penumbra's plugins are not the prefix's"
import json, os, sys
doc = json.load(open(sys.argv[1]))
own = os.path.realpath(sys.argv[2])
installed = sorted(f[len("penumbra-"):-len(".so")] for f in os.listdir(own) if f.startswith("penumbra-") and f.endswith(".so"))
problems = []
if [os.path.realpath(d) for d in doc["search_path"]] != [own]:
    problems.append(f"search path {doc['search_path']}, expected only {own}")
if sorted(p["name"] for p in doc["plugins"]) != installed:
    problems.append(f"plugins {sorted(p['name'] for p in doc['plugins'])}, installed {installed}")
for p in doc["plugins"]:
    if os.path.realpath(p["file"]) != os.path.join(own, f"penumbra-{p['name']}.so"):
        problems.append(f"{p['name']} loaded from {p['file']}")
problems += [f"{e['kind']}: {e['message']}" for e in doc["errors"]]
for problem in problems:
    print("out-of-tree:", problem, file=sys.stderr)
sys.exit(1 if problems else 0)
PY

# ... through the installed plugin scanner (libexec), never the build tree's: without it,
# every plugin is reported unscannable naming the installed scanner's path.
step "the installed penumbra scans with the installed scanner"
scanner="$prefix/libexec/penumbra/penumbra-plugin-scanner"
mv "$scanner" "$work/scanner"
rm -rf "$XDG_CACHE_HOME"
"$prefix/bin/penumbra" plugins >"$work/no-scanner.txt" 2>&1 || true
grep -q "libexec/penumbra/penumbra-plugin-scanner cannot be started" "$work/no-scanner.txt" \
  || { cat "$work/no-scanner.txt"; fail "without its installed scanner the installed penumbra still scanned plugins"; }
mv "$work/scanner" "$scanner"

step "build plugins/example against $prefix"
# The engine's compiler and the CI's warning flags: the example is the code people copy.
cmake -S "$root/plugins/example" -B "$example" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_CXX_COMPILER="$(cache_value CMAKE_CXX_COMPILER)" \
      -DCMAKE_CXX_FLAGS="-Wall -Wextra -Wno-missing-field-initializers -Werror" \
      >"$work/configure.log" 2>&1 || { cat "$work/configure.log"; fail "configuring plugins/example"; }
cmake --build "$example" >"$work/build.log" 2>&1 || { cat "$work/build.log"; fail "building plugins/example"; }
plugin="$example/plugins/penumbra-example.so"
[[ -f "$plugin" ]] || fail "no $plugin"
nm -D --defined-only "$plugin" | grep -qw penumbra_plugin_entry || fail "$plugin does not export penumbra_plugin_entry"
readelf -d "$plugin" | grep -q 'NEEDED.*\[libpenumbra_engine\.so\]' || fail "$plugin is not linked against libpenumbra_engine.so"

step "install the example into its own prefix"
cmake --install "$example" --prefix "$work/plugin-prefix" >/dev/null
for f in penumbra-example.so example/visibility.comp; do
  [[ -e "$work/plugin-prefix/lib/penumbra/plugins/$f" ]] || fail "the example's install lacks lib/penumbra/plugins/$f"
done

# Installed files name no folder of the machine they were built on: every run path is
# relative to the file ($ORIGIN).
step "installed run paths are relative"
while IFS= read -r f; do
  runpath=$(readelf -d "$f" 2>/dev/null | sed -n 's/.*(\(RUNPATH\|RPATH\)).*\[\(.*\)\]/\2/p')
  IFS=: read -ra entries <<<"$runpath"
  for e in "${entries[@]}"; do
    [[ $e == '$ORIGIN'* ]] || fail "$f: run path entry '$e' is not relative to \$ORIGIN"
  done
done < <(find "$prefix" "$work/plugin-prefix" -type f \( -name '*.so*' -o -perm -u+x \))

# The installed command finds the installed library (RUNPATH $ORIGIN/../lib) and the
# shaders installed next to it, not the source tree's. A missing installed shader must
# therefore be an error that names the prefix.
step "render with the installed penumbra"
unset PENUMBRA_SHADER_DIR PENUMBRA_PLUGIN_PATH
(cd "$work" && "$prefix/bin/penumbra" render "$root/config/default.json" -o "$work/installed.png" \
   --width 64 --height 48 >"$work/render.log" 2>&1) || { cat "$work/render.log"; fail "the installed penumbra does not render"; }
mv "$prefix/share/penumbra/shaders/engine/shading.glsl" "$work/shading.glsl"
if (cd "$work" && "$prefix/bin/penumbra" render "$root/config/default.json" -o "$work/no-shader.png" \
      --width 64 --height 48 >"$work/render.log" 2>&1); then
  fail "the installed penumbra rendered without its installed shading.glsl (it reads another shader folder)"
fi
grep -qF "$prefix/share/penumbra/shaders" "$work/render.log" || { cat "$work/render.log"; fail "the shader error does not name the installed folder"; }
mv "$work/shading.glsl" "$prefix/share/penumbra/shaders/engine/shading.glsl"

# The installed engine loads the out-of-tree build (ABI check, entry point, name) from
# PENUMBRA_PLUGIN_PATH.
step "the installed penumbra loads the example from PENUMBRA_PLUGIN_PATH"
# Only the out-of-tree build may declare "example" (DuplicateName otherwise); the build
# tree's copy is on no installed engine's search path (checked above).
rm -r "$prefix/lib/penumbra/plugins/penumbra-example.so" "$prefix/lib/penumbra/plugins/example"
PENUMBRA_PLUGIN_PATH="$example/plugins" "$prefix/bin/penumbra" plugins --json >"$work/plugins.json" 2>"$work/plugins.log" \
  || { cat "$work/plugins.log"; fail "penumbra plugins --json"; }
grep -Eq '"name"[[:space:]]*:[[:space:]]*"example"' "$work/plugins.json" \
  || { cat "$work/plugins.json" "$work/plugins.log"; fail "penumbra plugins --json does not list \"example\""; }
# The listing names the file it loaded (LoadedPlugin::file): the out-of-tree build.
grep -qF "$plugin" "$work/plugins.json" \
  || { cat "$work/plugins.json"; fail "penumbra plugins --json does not list $plugin"; }

step "render a frame with the example, installed in a prefix of its own, as a required technique"
cat >"$work/example.json" <<EOF
{"include": "$root/config/default.json",
 "lights": [{"type": "spot", "position": [-9, 16, 7], "target": [1.5, 0, 0], "outer_cone_deg": 42,
             "shadow": {"technique": "example", "required": true}}]}
EOF
(cd "$work" && PENUMBRA_PLUGIN_PATH="$work/plugin-prefix/lib/penumbra/plugins" "$prefix/bin/penumbra" render \
   "$work/example.json" -o "$work/example.png" --width 64 --height 48 >"$work/render.log" 2>&1) \
  || { cat "$work/render.log"; fail "the installed penumbra does not render with the out-of-tree example"; }
[[ -s "$work/example.png" ]] || fail "no $work/example.png"

# The installed plugin reads its installed shaders, not those of the tree it was built
# from (which exists here): with a broken installed visibility.comp it cannot render, and
# the error names the installed file.
step "the installed example reads its installed shaders"
installed_shader="$work/plugin-prefix/lib/penumbra/plugins/example/visibility.comp"
cp "$installed_shader" "$work/visibility.comp"
echo "this line is no GLSL" >>"$installed_shader"
if (cd "$work" && PENUMBRA_PLUGIN_PATH="$work/plugin-prefix/lib/penumbra/plugins" "$prefix/bin/penumbra" render \
      "$work/example.json" -o "$work/example-broken-shader.png" --width 64 --height 48 >"$work/render.log" 2>&1); then
  fail "the installed example rendered with a broken installed visibility.comp (it reads the source tree)"
fi
grep -qF "$installed_shader" "$work/render.log" || { cat "$work/render.log"; fail "the shader error does not name $installed_shader"; }
cp "$work/visibility.comp" "$installed_shader"

step "ok"

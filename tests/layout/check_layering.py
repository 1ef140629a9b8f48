#!/usr/bin/env python3
"""The engine's modules include each other only downwards (README.md "Layout"):

    apps -> frame -> {plugins, visibility, plugin} -> {render, config} -> {graph, scene} -> gpu

with core, io and metrics as leaves. Every `#include "penumbra/<module>/..."` (and, inside
the engine, every private `#include "<module>/..."`) in engine/include, engine/src and
plugins/ is an edge from the including file's module to <module>; an edge that does not go
to a lower layer (a plugin may include plugin/, the SDK it is written against) is a
module loop in the making and fails the check. Public headers must not include the
engine's private ones: an installed plugin could not find them.

Usage: check_layering.py <source root>. Exit status 1 with one line per offending
include, 0 otherwise.
"""
import pathlib
import re
import sys

# Higher includes lower. apps (not scanned) sit above everything.
LAYERS = {
    "frame": 6,
    "plugins": 5, "visibility": 5, "plugin": 5,
    "render": 4, "config": 4,
    "graph": 3, "scene": 3,
    "gpu": 2,
    "io": 1, "metrics": 1,
    "core": 0,
}
# Edges within a layer that the layering means: a plugin is written against plugin/.
ALLOWED_WITHIN_LAYER = {("plugins", "plugin")}

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
SOURCES = {".h", ".hpp", ".cpp"}


def module_of(path, root):
    parts = path.relative_to(root).parts
    if parts[:3] == ("engine", "include", "penumbra"):
        return parts[3]
    if parts[:2] == ("engine", "src"):
        return parts[2]
    if parts[0] == "plugins":
        return "plugins"
    return None


def included_module(target, private_allowed):
    parts = target.split("/")
    if len(parts) >= 3 and parts[0] == "penumbra":
        return parts[1], False
    if private_allowed and len(parts) >= 2 and parts[0] in LAYERS and parts[0] != "plugins":
        return parts[0], True
    return None, False


def main():
    root = pathlib.Path(sys.argv[1]).resolve()
    problems = []
    files = [p for d in ("engine/include", "engine/src", "plugins") for p in sorted((root / d).rglob("*"))
             if p.suffix in SOURCES and p.is_file()]
    for path in files:
        source = module_of(path, root)
        rel = path.relative_to(root)
        if source not in LAYERS:
            problems.append(f"{rel}: module '{source}' has no layer; add it to LAYERS in {pathlib.Path(__file__).name}")
            continue
        public = rel.parts[:2] == ("engine", "include")
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            match = INCLUDE.match(line)
            if not match:
                continue
            target, private = included_module(match.group(1), rel.parts[0] == "engine")
            if target is None or target == source:
                continue
            where = f"{rel}:{number}: {source} -> {target} (#include \"{match.group(1)}\")"
            if public and private:
                problems.append(f"{where}: a public header includes an engine-private one")
            elif target not in LAYERS:
                problems.append(f"{where}: module '{target}' has no layer")
            elif LAYERS[target] >= LAYERS[source] and (source, target) not in ALLOWED_WITHIN_LAYER:
                problems.append(f"{where}: layer {LAYERS[source]} may include only lower layers, "
                                f"and {target} is at layer {LAYERS[target]}")
    for problem in problems:
        print(problem)
    print(f"{len(files)} files checked, {len(problems)} layering problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())

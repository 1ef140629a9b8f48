#!/usr/bin/env python3
"""Facts the docs state that the code decides, checked so that they cannot drift:

- docs/plugins.md's "It is N since ..." names PENUMBRA_PLUGIN_ABI_VERSION
  (engine/include/penumbra/plugin/Plugin.h);
- no doc names a path of one machine (a home or work folder): commands in the docs run
  from the source root, with variables for anything outside it.

Usage: check_docs.py <source root>. Exit status 1 with one line per problem, 0 otherwise.
"""
import pathlib
import re
import sys

MACHINE_PATH = re.compile(r"(?<![\w.$])/(work|home|root|Users|mnt)/[\w.-]+")


def abi_problems(root):
    header = (root / "engine/include/penumbra/plugin/Plugin.h").read_text()
    defined = re.search(r"#define PENUMBRA_PLUGIN_ABI_VERSION (\d+)u", header)
    if not defined:
        return ["engine/include/penumbra/plugin/Plugin.h: no PENUMBRA_PLUGIN_ABI_VERSION"]
    stated = re.search(r"It is (\d+) since", (root / "docs/plugins.md").read_text())
    if not stated:
        return ["docs/plugins.md: no sentence \"It is N since ...\" stating the plugin ABI version"]
    if stated.group(1) != defined.group(1):
        return [f"docs/plugins.md: states plugin ABI {stated.group(1)}, Plugin.h defines {defined.group(1)}"]
    return []


def machine_path_problems(root):
    docs = [root / "README.md", *sorted((root / "docs").glob("*.md")), *sorted((root / "plugins").glob("*/README.md"))]
    problems = []
    for doc in docs:
        for number, line in enumerate(doc.read_text().splitlines(), 1):
            for match in MACHINE_PATH.finditer(line):
                problems.append(f"{doc.relative_to(root)}:{number}: a machine's path {match.group(0)}")
    return problems


def main():
    root = pathlib.Path(sys.argv[1])
    problems = abi_problems(root) + machine_path_problems(root)
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Facts the docs state that the code decides, checked so that they cannot drift:

- docs/plugins.md's "It is N since ..." names PENUMBRA_PLUGIN_ABI_VERSION, read from
  engine/include/penumbra/plugin/Plugin.h;
- no doc names a path of one machine (a home or work folder): commands in the docs run
  from the source root, with variables for anything outside it;
- every file of the repository a doc names exists: relative links and images, and paths
  (in backticks or in the text) that start with a top-level folder (`engine/src/...`,
  `config/x.json`) or with an engine module (`plugin/Technique.h`, read under
  engine/include/penumbra/ or engine/src/) or a shader folder (`common/shadow_map.glsl`,
  under shaders/); a doc's own folder counts too (a plugin's README names its files);
- with the programs given, every `penumbra` and `penumbra-viewer` command a doc quotes
  (in a code block or in backticks) names a subcommand the program has and only flags
  that its --help offers.

Usage: check_docs.py <source root> [--penumbra PROGRAM] [--viewer PROGRAM].
Exit status 1 with one line per problem, 0 otherwise.
"""
import argparse
import pathlib
import re
import shlex
import subprocess
import sys

MACHINE_PATH = re.compile(r"(?<![\w.$])/(work|home|root|Users|mnt)/[\w.-]+")

# Where a path a doc names may be read from, besides the root and the doc's folder.
TOP_FOLDERS = {"engine", "apps", "plugins", "shaders", "tests", "config", "docs", "assets"}
ENGINE_MODULES = {"config", "core", "frame", "gpu", "graph", "io", "metrics", "plugin", "render", "scene",
                  "visibility"}
SHADER_FOLDERS = {"common"}
INCLUDE_ROOTS = ["engine/include", "engine/include/penumbra", "engine/src", "shaders"]
# Files a doc tells the reader to write, which the repository therefore does not hold.
WRITTEN_BY_THE_READER = {"config/example-point.json"}

PATH = re.compile(r"(?<![\w./$~<{-])((?:[\w.+-]+/)+[\w.+-]*)")
LINK = re.compile(r"\]\(([^)\s]+)\)")
CODE_SPAN = re.compile(r"`([^`\n]+)`")
FENCE = re.compile(r"^\s*```")
SHELL_SEPARATORS = {"|", "||", "&&", ";", "&"}


def doc_files(root):
    return [root / "README.md", *sorted((root / "docs").glob("*.md")), *sorted((root / "plugins").glob("*/README.md"))]


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
    problems = []
    for doc in doc_files(root):
        for number, line in enumerate(doc.read_text().splitlines(), 1):
            for match in MACHINE_PATH.finditer(line):
                problems.append(f"{doc.relative_to(root)}:{number}: a machine's path {match.group(0)}")
    return problems


def names_a_repository_file(path):
    """Whether `path` (as a doc writes it) claims a file or folder of the repository: it
    starts with a top-level folder, an engine module or a shader folder, and holds no
    placeholder. Anything else (an output such as out/summary.md) is the reader's."""
    first = path.split("/")[0]
    if first not in TOP_FOLDERS | ENGINE_MODULES | SHADER_FOLDERS:
        return False
    # A folder below a module is named in a listing of that module's parent (README's
    # layout table): only top-level folders are checked on their own.
    return not (path.endswith("/") and first not in TOP_FOLDERS)


def exists(root, doc, path):
    bases = [root, doc.parent, *(root / r for r in INCLUDE_ROOTS)]
    return any((base / path).exists() for base in bases)


def missing_file_problems(root):
    problems = []
    for doc in doc_files(root):
        where = doc.relative_to(root)
        for number, line in enumerate(doc.read_text().splitlines(), 1):
            for match in LINK.finditer(line):
                target = match.group(1).split("#")[0]
                if not target or re.match(r"[a-z]+:", target):
                    continue
                if not (doc.parent / target).exists():
                    problems.append(f"{where}:{number}: links to {target}, which does not exist")
            for match in PATH.finditer(line):
                path = match.group(1).rstrip(".")
                if line[match.end():match.end() + 1] in "<{*$" or not names_a_repository_file(path):
                    continue
                if path not in WRITTEN_BY_THE_READER and not exists(root, doc, path):
                    problems.append(f"{where}:{number}: names {path}, which does not exist")
    return problems


def help_flags(program, *command):
    """The flags `program command --help` lists (both spellings of "-o,--output")."""
    result = subprocess.run([program, *command, "--help"], capture_output=True, text=True, errors="replace",
                            timeout=60)
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join([program, *command])} --help: exit {result.returncode}: {result.stderr.strip()}")
    flags = set()
    for line in result.stdout.splitlines():
        words = line.split()
        if words and words[0].startswith("-"):
            flags.update(words[0].split(","))
    return flags, result.stdout


def subcommands(help_text):
    names = []
    in_list = False
    for line in help_text.splitlines():
        if line.startswith("Subcommands:"):
            in_list = True
        elif in_list and line.startswith("  ") and line.split():
            names.append(line.split()[0])
        elif in_list and line.strip():
            in_list = False
    return names


def quoted_commands(text):
    """The command lines a doc quotes: each line of a code block (with its backslash
    continuations) and each span in backticks."""
    in_block = False
    pending = ""
    for number, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            in_block = not in_block
            continue
        if in_block:
            if line.rstrip().endswith("\\"):
                pending += line.rstrip()[:-1] + " "
                continue
            yield number, pending + line
            pending = ""
        else:
            for span in CODE_SPAN.finditer(line):
                yield number, span.group(1)


def words_of(command):
    try:
        return shlex.split(command, comments=True)
    except ValueError:  # an unbalanced quote in prose: the words as written
        return command.split()


def invocations(words, program_name):
    """The argument lists that follow each `program_name` word, up to a shell separator."""
    for at, word in enumerate(words):
        if word == program_name or (word.endswith("/" + program_name) and "=" not in word):
            args = []
            for arg in words[at + 1:]:
                if arg in SHELL_SEPARATORS or arg.startswith((">", "2>", "<")):
                    break
                args.append(arg)
            yield args


def flag_problems(args, flags, where, command):
    """A synopsis writes alternatives and optional parts as `[-v|--verbose]`: each
    spelling is held to the flags."""
    problems = []
    for arg in args:
        for spelling in arg.strip("[]()").split("|"):
            if spelling.startswith("-") and not re.fullmatch(r"-?\d[\d.]*", spelling):
                flag = spelling.split("=")[0]
                if flag not in flags:
                    problems.append(f"{where}: `{command}` has no flag {flag}")
    return problems


def command_problems(root, penumbra, viewer):
    programs = {}
    try:
        if penumbra:
            global_flags, help_text = help_flags(penumbra)
            programs["penumbra"] = (global_flags,
                                    {name: help_flags(penumbra, name)[0] for name in subcommands(help_text)})
        if viewer:
            programs["penumbra-viewer"] = (help_flags(viewer)[0], None)
    except (OSError, RuntimeError, subprocess.TimeoutExpired) as e:
        return [f"cannot read the programs' flags: {e}"]
    problems = []
    for doc in doc_files(root):
        for number, command in quoted_commands(doc.read_text()):
            words = words_of(command)
            for name, (global_flags, subcommand_flags) in programs.items():
                for args in invocations(words, name):
                    where = f"{doc.relative_to(root)}:{number}"
                    if subcommand_flags is None:
                        problems += flag_problems(args, global_flags, where, name)
                        continue
                    first = next((i for i, a in enumerate(args) if not a.startswith("-")), len(args))
                    problems += flag_problems(args[:first], global_flags, where, name)
                    if first == len(args) or not re.fullmatch(r"[a-z][a-z-]*", args[first]):
                        continue  # the program named, not run (`penumbra CONFIG`, a placeholder)
                    subcommand = args[first]
                    if subcommand not in subcommand_flags:
                        problems.append(f"{where}: `{name} {subcommand}`: {name} has no subcommand {subcommand}")
                        continue
                    problems += flag_problems(args[first + 1:], subcommand_flags[subcommand], where,
                                              f"{name} {subcommand}")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=pathlib.Path)
    parser.add_argument("--penumbra", help="the penumbra program, whose --help the quoted commands are held to")
    parser.add_argument("--viewer", help="the penumbra-viewer program, likewise")
    options = parser.parse_args()
    root = options.root
    problems = (abi_problems(root) + machine_path_problems(root) + missing_file_problems(root) +
                command_problems(root, options.penumbra, options.viewer))
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())

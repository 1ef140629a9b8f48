#!/usr/bin/env python3
"""Damaged copies of a small ELF64 little-endian shared object, one per way the plugin
pre-load check (engine/src/plugin/LibraryFile.cpp) must refuse a file before dlopen sees
it: seeds for the plugin_file fuzz target (tests/fuzz/run.sh), so that a regression in
any of those checks lies a few mutations from a seed.

Usage: damage_elf.py SHARED_OBJECT OUT_DIR. Writes OUT_DIR/<name>-<damage> per damage.
"""
import pathlib
import struct
import sys

PT_DYNAMIC = 2
# d_tag values (elf.h) whose d_val is an address or a size the check bounds.
DT = {"needed": 1, "hash": 4, "strtab": 5, "symtab": 6, "rela": 7, "relasz": 8, "strsz": 10, "init": 12, "fini": 13,
      "soname": 14, "init_array": 25, "fini_array": 26, "init_arraysz": 27, "fini_arraysz": 28, "gnu_hash": 0x6FFFFEF5,
      "versym": 0x6FFFFFF0}
FAR = 0x7FFF_FFFF_F000


def dynamic_entries(elf):
    """(offset of the entry's d_val, d_tag) for every entry of the dynamic section."""
    phoff, = struct.unpack_from("<Q", elf, 0x20)
    phentsize, phnum = struct.unpack_from("<HH", elf, 0x36)
    for i in range(phnum):
        p_type, _, p_offset, _, _, p_filesz = struct.unpack_from("<IIQQQQ", elf, phoff + i * phentsize)
        if p_type != PT_DYNAMIC:
            continue
        for at in range(p_offset, p_offset + p_filesz, 16):
            tag, = struct.unpack_from("<q", elf, at)
            if tag == 0:
                return
            yield at + 8, tag


def damages(elf):
    """(name, damaged copy) pairs."""
    header = {"foreign-machine": (0x12, struct.pack("<H", 183)),  # EM_AARCH64
              "big-endian": (5, b"\x02"), "elfclass32": (4, b"\x01")}
    for name, (at, value) in header.items():
        copy = bytearray(elf)
        copy[at:at + len(value)] = value
        yield name, copy
    for at, tag in dynamic_entries(elf):
        for name, known in DT.items():
            if tag != known:
                continue
            # Addresses far outside every segment; sizes beyond the file; string offsets
            # past the string table.
            value = 1 << 40 if name.endswith("sz") else (FAR if name not in ("needed", "soname") else 1 << 30)
            copy = bytearray(elf)
            struct.pack_into("<Q", copy, at, value)
            yield f"dyn-{name}", copy


def main():
    source, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    elf = source.read_bytes()
    if elf[:4] != b"\x7fELF" or elf[4] != 2 or elf[5] != 1:
        sys.exit(f"{source}: not an ELF64 little-endian file")
    written = 0
    for name, copy in damages(elf):
        (out / f"{source.name}-{name}").write_bytes(copy)
        written += 1
    print(f"damage_elf: {written} damaged copies of {source.name}")


if __name__ == "__main__":
    main()

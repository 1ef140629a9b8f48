#include "penumbra/plugin/LibraryFile.h"

#include "penumbra/io/ReadFile.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>

#include <link.h>

#include <algorithm>
#include <cstring>
#include <optional>
#include <vector>

namespace fs = std::filesystem;

// The linker's symbol for the ELF header of the module that holds this code (the engine
// library): its machine and byte order are the ones a plugin must share.
extern "C" const ElfW(Ehdr) __ehdr_start __attribute__((visibility("hidden")));

namespace penumbra::plugin {
namespace {

// No real plugin comes near these; a damaged count must not make the check read or
// allocate without bound.
constexpr uint64_t kMaxLibraryBytes = uint64_t(1) << 30;
constexpr uint64_t kMaxDynamicEntries = 4096;
constexpr uint64_t kMaxSymbols = uint64_t(1) << 22;
constexpr uint64_t kMaxRelocations = uint64_t(1) << 24;
constexpr uint64_t kMaxLoaderString = 4096;  // a DT_NEEDED name, a run path

std::string machineName(uint16_t machine)
{
    switch (machine) {
    case EM_X86_64: return "x86-64";
    case EM_386: return "x86 (32-bit)";
    case EM_AARCH64: return "AArch64";
    case EM_ARM: return "ARM (32-bit)";
    case EM_RISCV: return "RISC-V";
    case EM_PPC64: return "PowerPC 64";
    case EM_S390: return "s390";
    default: return fmt::format("machine {}", machine);
    }
}

// r_info's halves, as ELF64_R_TYPE/ELF64_R_SYM and ELF32_R_TYPE/ELF32_R_SYM split them.
uint32_t relocationType(uint64_t info) { return sizeof(void*) == 8 ? uint32_t(info & 0xffffffffu) : uint32_t(info & 0xffu); }
uint64_t relocationSymbol(uint64_t info) { return sizeof(void*) == 8 ? info >> 32 : info >> 8; }

const char* byteOrderName(unsigned char data) { return data == ELFDATA2MSB ? "big-endian" : "little-endian"; }

// Relocation types glibc's loader applies; any other makes it stop the process ("unexpected
// reloc type", exit 127) instead of failing dlopen. Known per machine: elsewhere unchecked.
bool loaderKnowsRelocation(uint32_t type)
{
#if defined(__x86_64__)
    switch (type) {
    case R_X86_64_NONE: case R_X86_64_64: case R_X86_64_PC32: case R_X86_64_COPY: case R_X86_64_GLOB_DAT:
    case R_X86_64_JUMP_SLOT: case R_X86_64_RELATIVE: case R_X86_64_32: case R_X86_64_DTPMOD64:
    case R_X86_64_DTPOFF64: case R_X86_64_TPOFF64: case R_X86_64_SIZE32: case R_X86_64_SIZE64:
    case R_X86_64_TLSDESC: case R_X86_64_IRELATIVE: return true;
    default: return false;
    }
#else
    (void)type;
    return true;
#endif
}

bool isRelative(uint32_t type)
{
#if defined(__x86_64__)
    return type == R_X86_64_RELATIVE;
#elif defined(__aarch64__)
    return type == R_AARCH64_RELATIVE;
#else
    (void)type;
    return false;
#endif
}

// The whole check of one file. Every read is bounded: headers, the dynamic section, the
// tables it names (symbols, relocations, hash tables) each at most the file's size and a
// fixed count, so a damaged count cannot make it read or allocate more.
class LibraryCheck {
public:
    LibraryCheck(const fs::path& file, std::string who) : path_(file), who_(std::move(who)) {}

    void run()
    {
        openFile();
        checkHeader();
        readSegments();
        checkDynamicSection();
        checkTables();
        checkStrings();
        checkRelocations();
        checkSymbols();
        checkVersions();
        checkInitAndFini();
    }

private:
    [[noreturn]] void fail(const std::string& what) const
    {
        throw PluginError(PluginErrorKind::NotALibrary,
                          fmt::format("{}: not a shared library: {}; rebuild the plugin (a CMake MODULE library) or "
                                      "remove the file from the plugin search path",
                                      who_, what),
                          path_);
    }
    [[noreturn]] void damaged(const std::string& what) const
    {
        fail(fmt::format("it is damaged or truncated ({} bytes): {}", size_, what));
    }

    // The reasons read "is a FIFO (named pipe), expected ...", "cannot be read: ...".
    [[noreturn]] void refuseUnreadable(const io::FileReadError& e) const
    {
        fail(e.problem() == io::FileReadProblem::NotFound && e.reason() == "not found" ? "it does not exist"
                                                                                       : fmt::format("it {}", e.reason()));
    }

    bool within(uint64_t offset, uint64_t bytes) const { return offset <= size_ && bytes <= size_ - offset; }

    void read(uint64_t offset, void* out, uint64_t bytes, const std::string& what)
    {
        if (!within(offset, bytes)) damaged(fmt::format("{} lies beyond the file's end", what));
        try {
            if (file_->readAt(offset, out, bytes) != bytes) damaged(fmt::format("{} cannot be read", what));
        } catch (const io::FileReadError& e) {
            refuseUnreadable(e);
        }
    }
    template <typename T>
    std::vector<T> readArray(uint64_t offset, uint64_t count, const std::string& what)
    {
        if (count > size_ / sizeof(T)) damaged(fmt::format("{} lies beyond the file's end", what));
        std::vector<T> items(count);
        read(offset, items.data(), count * sizeof(T), what);
        return items;
    }

    void openFile()
    {
        try {
            file_.emplace(path_, kMaxLibraryBytes, "a plugin library");
        } catch (const io::FileReadError& e) {
            refuseUnreadable(e);
        }
        size_ = file_->reportedSize();
    }

    // Identity first, each field read only once the ones before it say how: a 32-bit or
    // big-endian file lays out the rest of its header differently.
    void checkHeader()
    {
        const size_t got = std::min<uint64_t>(size_, sizeof header_);
        read(0, &header_, got, "its ELF header");
        if (got < SELFMAG || std::memcmp(header_.e_ident, ELFMAG, SELFMAG) != 0) fail("it is not an ELF file");
        if (got < EI_NIDENT) fail(fmt::format("the ELF header is truncated ({} bytes)", got));
        const ElfW(Ehdr)& own = __ehdr_start;
        if (header_.e_ident[EI_CLASS] != own.e_ident[EI_CLASS]) {
            const unsigned char cls = header_.e_ident[EI_CLASS];
            fail(fmt::format("it is a {} ELF file, this engine is {}-bit",
                             cls == ELFCLASS32 ? "32-bit" : cls == ELFCLASS64 ? "64-bit" : fmt::format("class-{}", cls),
                             sizeof(void*) * 8));
        }
        if (header_.e_ident[EI_DATA] != own.e_ident[EI_DATA]) {
            fail(fmt::format("it is a {} ELF file, this engine is {}",
                             header_.e_ident[EI_DATA] == ELFDATA2LSB || header_.e_ident[EI_DATA] == ELFDATA2MSB
                                 ? byteOrderName(header_.e_ident[EI_DATA])
                                 : "wrongly encoded (byte order unknown)",
                             byteOrderName(own.e_ident[EI_DATA])));
        }
        if (got < sizeof header_) fail(fmt::format("the ELF header is truncated ({} bytes)", got));
        if (header_.e_machine != own.e_machine) {
            fail(fmt::format("it is built for another architecture ({}), this engine runs on {}",
                             machineName(header_.e_machine), machineName(own.e_machine)));
        }
        if (header_.e_ident[EI_VERSION] != EV_CURRENT || header_.e_version != EV_CURRENT) {
            damaged("its ELF version is not 1");
        }
        if (header_.e_type != ET_DYN) fail("it is an ELF executable or object file, not a shared object");
        if (header_.e_phentsize != sizeof(ElfW(Phdr)) || header_.e_phnum == 0 || header_.e_phnum == PN_XNUM ||
            !within(header_.e_phoff, uint64_t(header_.e_phnum) * sizeof(ElfW(Phdr)))) {
            damaged("its program header table lies beyond the file's end or is malformed");
        }
        if (header_.e_shoff != 0 && (header_.e_shentsize != sizeof(ElfW(Shdr)) ||
                                     !within(header_.e_shoff, uint64_t(header_.e_shnum) * sizeof(ElfW(Shdr))))) {
            damaged("its section header table lies beyond the file's end or is malformed");
        }
    }

    // The segments the loader maps: inside the file, in address order, not overlapping,
    // and the dynamic, TLS and RELRO segments inside them.
    void readSegments()
    {
        const std::vector<ElfW(Phdr)> segments = readArray<ElfW(Phdr)>(header_.e_phoff, header_.e_phnum, "its program headers");
        const ElfW(Phdr)* previous = nullptr;
        for (size_t i = 0; i < segments.size(); ++i) {
            const ElfW(Phdr)& p = segments[i];
            const bool checked = p.p_type == PT_LOAD || p.p_type == PT_DYNAMIC || p.p_type == PT_TLS;
            if (checked && !within(p.p_offset, p.p_filesz)) {
                damaged(fmt::format("segment {} (bytes {} to {}) lies beyond the file's end", i, uint64_t(p.p_offset),
                                    uint64_t(p.p_offset) + uint64_t(p.p_filesz)));
            }
            if (checked && p.p_filesz > p.p_memsz) damaged(fmt::format("segment {} holds more bytes in the file than in memory", i));
            if (checked && p.p_align > 1 && (p.p_align & (p.p_align - 1)) != 0) damaged(fmt::format("segment {} is misaligned", i));
            if (p.p_type == PT_LOAD) {
                if (p.p_memsz > ~uint64_t(0) - p.p_vaddr) damaged(fmt::format("segment {} wraps around the address space", i));
                if (p.p_align > 1 && p.p_offset % p.p_align != p.p_vaddr % p.p_align) damaged(fmt::format("segment {} is misaligned", i));
                if (previous && p.p_vaddr < previous->p_vaddr + previous->p_memsz) {
                    damaged(fmt::format("segment {} overlaps or precedes the loadable segment before it", i));
                }
                previous = &p;
                loads_.push_back(p);
            } else if (p.p_type == PT_DYNAMIC) {
                if (dynamic_) damaged("it has two dynamic segments");
                dynamic_ = p;
            } else if (p.p_type == PT_GNU_RELRO || p.p_type == PT_TLS) {
                others_.push_back({i, p});
            }
        }
        if (loads_.empty() || !dynamic_) damaged("it has no loadable or no dynamic segment");
        for (const auto& [i, p] : others_) {
            if (p.p_filesz > 0 && !fileBacked(p.p_vaddr, p.p_filesz)) {
                damaged(fmt::format("segment {} ({}) lies outside the loadable segments", i,
                                    p.p_type == PT_TLS ? "thread-local data" : "read-only after relocation"));
            }
        }
        if (!fileBacked(dynamic_->p_vaddr, dynamic_->p_filesz) ||
            fileOffsetOf(dynamic_->p_vaddr, dynamic_->p_filesz) != dynamic_->p_offset) {
            damaged("the dynamic segment lies outside the loadable segments");
        }
    }

    // The loadable segment whose file bytes hold [address, address + bytes).
    const ElfW(Phdr)* loadHolding(uint64_t address, uint64_t bytes, bool inFile) const
    {
        for (const ElfW(Phdr)& p : loads_) {
            const uint64_t extent = inFile ? p.p_filesz : p.p_memsz;
            if (address >= p.p_vaddr && address - p.p_vaddr <= extent && bytes <= extent - (address - p.p_vaddr)) return &p;
        }
        return nullptr;
    }
    bool fileBacked(uint64_t address, uint64_t bytes) const { return loadHolding(address, bytes, true) != nullptr; }
    bool mapped(uint64_t address, uint64_t bytes) const { return loadHolding(address, bytes, false) != nullptr; }
    bool executable(uint64_t address) const
    {
        const ElfW(Phdr)* p = loadHolding(address, 1, false);
        return p && (p->p_flags & PF_X) != 0;
    }
    uint64_t fileOffsetOf(uint64_t address, uint64_t bytes) const
    {
        const ElfW(Phdr)* p = loadHolding(address, bytes, true);
        return p ? p->p_offset + (address - p->p_vaddr) : ~uint64_t(0);
    }

    // An address the dynamic section gives for a table of `bytes` bytes: the table must lie
    // in the file bytes of a loadable segment, where the loader reads it.
    uint64_t tableOffset(int64_t tag, uint64_t bytes, const std::string& name)
    {
        const uint64_t address = dyn(tag).value_or(0);
        if (!fileBacked(address, bytes)) {
            damaged(fmt::format("its dynamic section's {} (address {:#x}, {} bytes) lies outside every loadable "
                                "segment's file bytes",
                                name, address, bytes));
        }
        return fileOffsetOf(address, bytes);
    }

    std::optional<uint64_t> dyn(int64_t tag) const
    {
        for (const ElfW(Dyn)& d : entries_)
            if (d.d_tag == tag) return uint64_t(d.d_un.d_val);
        return std::nullopt;
    }

    void checkDynamicSection()
    {
        const uint64_t count = dynamic_->p_filesz / sizeof(ElfW(Dyn));
        if (dynamic_->p_filesz % sizeof(ElfW(Dyn)) != 0 || count == 0 || count > kMaxDynamicEntries) {
            damaged(fmt::format("its dynamic section's size ({} bytes) is not a whole number of entries", uint64_t(dynamic_->p_filesz)));
        }
        const std::vector<ElfW(Dyn)> all = readArray<ElfW(Dyn)>(dynamic_->p_offset, count, "its dynamic section");
        const auto end = std::find_if(all.begin(), all.end(), [](const ElfW(Dyn)& d) { return d.d_tag == DT_NULL; });
        if (end == all.end()) damaged("its dynamic section has no end marker (DT_NULL)");
        entries_.assign(all.begin(), end);
        for (const int64_t tag : {DT_STRTAB, DT_SYMTAB, DT_STRSZ}) {
            if (!dyn(tag)) damaged("its dynamic section lacks the string or symbol table (DT_STRTAB, DT_SYMTAB, DT_STRSZ)");
        }
        if (!dyn(DT_HASH) && !dyn(DT_GNU_HASH)) damaged("its dynamic section has no symbol hash table (DT_HASH, DT_GNU_HASH)");
        if (dyn(DT_SYMENT).value_or(sizeof(ElfW(Sym))) != sizeof(ElfW(Sym)) ||
            dyn(DT_RELAENT).value_or(sizeof(ElfW(Rela))) != sizeof(ElfW(Rela)) ||
            dyn(DT_RELENT).value_or(sizeof(ElfW(Rel))) != sizeof(ElfW(Rel))) {
            damaged("its dynamic section gives a symbol or relocation entry size that is not this format's");
        }
        if (dyn(DT_PLTREL) && *dyn(DT_PLTREL) != DT_RELA && *dyn(DT_PLTREL) != DT_REL) {
            damaged("its dynamic section's DT_PLTREL is neither DT_RELA nor DT_REL");
        }
        if (dyn(DT_PLTGOT) && !mapped(*dyn(DT_PLTGOT), sizeof(void*))) {
            damaged(fmt::format("its dynamic section's DT_PLTGOT ({:#x}) lies outside every loadable segment", *dyn(DT_PLTGOT)));
        }
        for (const auto& [tag, name] : {std::pair{DT_INIT, "DT_INIT"}, std::pair{DT_FINI, "DT_FINI"}}) {
            if (dyn(tag) && !executable(*dyn(tag))) {
                damaged(fmt::format("its dynamic section's {} ({:#x}) lies outside every executable segment", name, *dyn(tag)));
            }
        }
    }

    // Every table the dynamic section names, with its size where the section gives one.
    void checkTables()
    {
        strtab_ = tableOffset(DT_STRTAB, *dyn(DT_STRSZ), "string table (DT_STRTAB, DT_STRSZ)");
        symtab_ = tableOffset(DT_SYMTAB, sizeof(ElfW(Sym)), "symbol table (DT_SYMTAB)");
        symbolCount_ = countSymbols();
        const struct {
            int64_t tag, sizeTag;
            const char* name;
        } sized[] = {
            {DT_RELA, DT_RELASZ, "relocations (DT_RELA, DT_RELASZ)"},
            {DT_REL, DT_RELSZ, "relocations (DT_REL, DT_RELSZ)"},
#ifdef DT_RELR
            {DT_RELR, DT_RELRSZ, "relative relocations (DT_RELR, DT_RELRSZ)"},
#endif
            {DT_JMPREL, DT_PLTRELSZ, "PLT relocations (DT_JMPREL, DT_PLTRELSZ)"},
            {DT_INIT_ARRAY, DT_INIT_ARRAYSZ, "initialiser array (DT_INIT_ARRAY, DT_INIT_ARRAYSZ)"},
            {DT_FINI_ARRAY, DT_FINI_ARRAYSZ, "finaliser array (DT_FINI_ARRAY, DT_FINI_ARRAYSZ)"},
            {DT_PREINIT_ARRAY, DT_PREINIT_ARRAYSZ, "pre-initialiser array (DT_PREINIT_ARRAY, DT_PREINIT_ARRAYSZ)"},
        };
        for (const auto& t : sized) {
            if (!dyn(t.tag) && !dyn(t.sizeTag)) continue;
            tableOffset(t.tag, dyn(t.sizeTag).value_or(0), t.name);
        }
        if (dyn(DT_VERSYM)) tableOffset(DT_VERSYM, symbolCount_ * sizeof(ElfW(Versym)), "symbol versions (DT_VERSYM)");
        if (dyn(DT_VERNEED)) {
            tableOffset(DT_VERNEED, dyn(DT_VERNEEDNUM).value_or(1) * sizeof(ElfW(Verneed)), "needed versions (DT_VERNEED, DT_VERNEEDNUM)");
        }
        if (dyn(DT_VERDEF)) {
            tableOffset(DT_VERDEF, dyn(DT_VERDEFNUM).value_or(1) * sizeof(ElfW(Verdef)), "defined versions (DT_VERDEF, DT_VERDEFNUM)");
        }
    }

    // How many symbols the loader may look up: DT_HASH says it (nchain); DT_GNU_HASH holds
    // it in its chains (the last symbol of the highest bucket's chain).
    uint64_t countSymbols()
    {
        uint64_t count = 0;
        if (dyn(DT_HASH)) {
            uint32_t sizes[2];  // nbucket, nchain
            read(tableOffset(DT_HASH, sizeof sizes, "hash table (DT_HASH)"), sizes, sizeof sizes, "its hash table");
            tableOffset(DT_HASH, (2 + uint64_t(sizes[0]) + sizes[1]) * 4, "hash table (DT_HASH, its buckets and chains)");
            count = sizes[1];
        }
        if (dyn(DT_GNU_HASH)) {
            uint32_t head[4];  // nbuckets, symoffset, bloom words, bloom shift
            const uint64_t at = tableOffset(DT_GNU_HASH, sizeof head, "GNU hash table (DT_GNU_HASH)");
            read(at, head, sizeof head, "its GNU hash table");
            const uint64_t bucketsAt = sizeof head + uint64_t(head[2]) * sizeof(ElfW(Addr));
            tableOffset(DT_GNU_HASH, bucketsAt + uint64_t(head[0]) * 4, "GNU hash table (DT_GNU_HASH, its bloom filter and buckets)");
            if (head[0] == 0 || head[2] == 0 || (head[2] & (head[2] - 1)) != 0) {
                damaged("its GNU hash table (DT_GNU_HASH) has no buckets or a bloom filter whose size is not a power of two");
            }
            const std::vector<uint32_t> buckets = readArray<uint32_t>(at + bucketsAt, head[0], "its GNU hash buckets");
            const uint32_t highest = *std::max_element(buckets.begin(), buckets.end());
            uint64_t gnuCount = std::max<uint64_t>(highest + uint64_t(1), head[1]);
            if (highest >= head[1]) {
                const uint64_t chainsAt = bucketsAt + uint64_t(head[0]) * 4;
                for (uint64_t symbol = highest;; ++symbol) {
                    if (symbol - head[1] > kMaxSymbols) damaged("its GNU hash table's last chain does not end");
                    const uint64_t link = chainsAt + (symbol - head[1]) * 4;
                    uint32_t hash = 0;
                    read(tableOffset(DT_GNU_HASH, link + 4, "GNU hash table (DT_GNU_HASH, its chains)") + link, &hash,
                         sizeof hash, "its GNU hash chains");
                    if (hash & 1u) {
                        gnuCount = symbol + 1;
                        break;
                    }
                }
            }
            count = std::max(count, gnuCount);
        }
        if (count > kMaxSymbols) damaged(fmt::format("its hash table counts {} symbols", count));
        return count;
    }

    // A string the loader reads (a needed library's name, a run path): inside the string
    // table and ended there.
    void checkString(uint64_t offset, const std::string& what)
    {
        const uint64_t tableSize = *dyn(DT_STRSZ);
        if (offset >= tableSize) {
            damaged(fmt::format("{} (string {} of a {}-byte string table) lies outside the string table", what, offset, tableSize));
        }
        std::vector<char> text(std::min(kMaxLoaderString, tableSize - offset));
        read(strtab_ + offset, text.data(), text.size(), what);
        if (std::find(text.begin(), text.end(), '\0') == text.end()) damaged(fmt::format("{} does not end inside the string table", what));
    }

    void checkStrings()
    {
        for (const ElfW(Dyn)& d : entries_) {
            const char* name = d.d_tag == DT_NEEDED    ? "a needed library's name (DT_NEEDED)"
                               : d.d_tag == DT_SONAME  ? "its own name (DT_SONAME)"
                               : d.d_tag == DT_RPATH   ? "its run path (DT_RPATH)"
                               : d.d_tag == DT_RUNPATH ? "its run path (DT_RUNPATH)"
                                                       : nullptr;
            if (name) checkString(d.d_un.d_val, name);
        }
    }

    // Symbols the loader resolves against: names inside the string table, defined
    // functions inside executable code and other definitions inside the mapped segments
    // (dlsym would hand out a wild pointer).
    void checkSymbols()
    {
        // The hash tables count the symbols they find by name; relocations may name
        // unhashed ones beyond (GNU_HASH leaves undefined symbols out).
        symbolCount_ = std::max(symbolCount_, highestRelocationSymbol_ + 1);
        tableOffset(DT_SYMTAB, symbolCount_ * sizeof(ElfW(Sym)),
                    fmt::format("symbol table (DT_SYMTAB, the {} symbols its hash table and relocations use)", symbolCount_));
        const std::vector<ElfW(Sym)> symbols = readArray<ElfW(Sym)>(symtab_, symbolCount_, "its symbol table");
        const uint64_t tableSize = *dyn(DT_STRSZ);
        for (size_t i = 0; i < symbols.size(); ++i) {
            const ElfW(Sym)& s = symbols[i];
            if (s.st_name >= tableSize && !(i == 0 && s.st_name == 0)) {
                damaged(fmt::format("symbol {}'s name (string {}) lies outside the {}-byte string table", i, s.st_name, tableSize));
            }
            if (s.st_shndx == SHN_UNDEF || s.st_shndx == SHN_ABS || ELF64_ST_TYPE(s.st_info) == STT_TLS) continue;
            const bool function = ELF64_ST_TYPE(s.st_info) == STT_FUNC || ELF64_ST_TYPE(s.st_info) == STT_GNU_IFUNC;
            if (function ? !executable(s.st_value) : !mapped(s.st_value, 0)) {
                damaged(fmt::format("symbol {}'s address ({:#x}) lies outside every {} segment", i, uint64_t(s.st_value),
                                    function ? "executable" : "loadable"));
            }
        }
    }

    void checkRelocation(uint64_t target, uint32_t type, uint64_t symbol, const std::string& what)
    {
        if (!loaderKnowsRelocation(type)) damaged(fmt::format("{} has a relocation type the loader does not know ({})", what, type));
        if (!mapped(target, sizeof(ElfW(Addr)))) {
            damaged(fmt::format("{} writes to {:#x}, outside every loadable segment", what, target));
        }
        if (symbol >= kMaxSymbols) damaged(fmt::format("{} names symbol {}", what, symbol));
        highestRelocationSymbol_ = std::max(highestRelocationSymbol_, symbol);
    }

    // The symbol version tables the loader walks by their own offsets: every needed and
    // defined version inside the tables, its names inside the string table, and every
    // symbol's version index one of them (the loader indexes its version array with it).
    void checkVersions()
    {
        uint64_t highestIndex = 1;  // 0 local, 1 global: always there
        const auto walk = [&](int64_t tag, int64_t countTag, const char* name, auto&& visit) {
            if (!dyn(tag)) return;
            const uint64_t count = dyn(countTag).value_or(0);
            if (count > kMaxDynamicEntries) damaged(fmt::format("its {} count {} entries", name, count));
            uint64_t at = 0;  // from the table's start
            for (uint64_t i = 0; i < count; ++i) {
                const uint64_t next = visit(at, fmt::format("{} entry {}", name, i));
                if (next == 0) break;
                if (next > ~uint64_t(0) - at) damaged(fmt::format("its {} entry {} points nowhere", name, i));
                at += next;
            }
        };
        walk(DT_VERNEED, DT_VERNEEDNUM, "needed versions (DT_VERNEED)", [&](uint64_t at, const std::string& what) {
            ElfW(Verneed) need{};
            read(tableOffset(DT_VERNEED, at + sizeof need, what) + at, &need, sizeof need, what);
            if (need.vn_version != 1) damaged(fmt::format("{} has version {}, not 1", what, need.vn_version));
            checkString(need.vn_file, what + "'s library name");
            uint64_t aux = at + need.vn_aux;
            for (uint32_t j = 0; j < need.vn_cnt && j < kMaxDynamicEntries; ++j) {
                ElfW(Vernaux) v{};
                read(tableOffset(DT_VERNEED, aux + sizeof v, what) + aux, &v, sizeof v, what);
                checkString(v.vna_name, what + "'s version name");
                highestIndex = std::max<uint64_t>(highestIndex, v.vna_other & 0x7fff);
                if (v.vna_next == 0) break;
                aux += v.vna_next;
            }
            return uint64_t(need.vn_next);
        });
        walk(DT_VERDEF, DT_VERDEFNUM, "defined versions (DT_VERDEF)", [&](uint64_t at, const std::string& what) {
            ElfW(Verdef) def{};
            read(tableOffset(DT_VERDEF, at + sizeof def, what) + at, &def, sizeof def, what);
            if (def.vd_version != 1) damaged(fmt::format("{} has version {}, not 1", what, def.vd_version));
            highestIndex = std::max<uint64_t>(highestIndex, def.vd_ndx & 0x7fff);
            if (def.vd_cnt > 0) {
                const uint64_t aux = at + def.vd_aux;
                ElfW(Verdaux) v{};
                read(tableOffset(DT_VERDEF, aux + sizeof v, what) + aux, &v, sizeof v, what);
                checkString(v.vda_name, what + "'s version name");
            }
            return uint64_t(def.vd_next);
        });
        if (!dyn(DT_VERSYM)) return;
        const std::vector<ElfW(Versym)> versions = readArray<ElfW(Versym)>(
            tableOffset(DT_VERSYM, symbolCount_ * sizeof(ElfW(Versym)), "symbol versions (DT_VERSYM)"), symbolCount_,
            "its symbol versions");
        for (size_t i = 0; i < versions.size(); ++i) {
            if ((versions[i] & 0x7fff) > highestIndex) {
                damaged(fmt::format("symbol {}'s version index {} names no version of its version tables", i, versions[i] & 0x7fff));
            }
        }
    }

    bool inInitOrFiniArray(uint64_t address) const
    {
        for (const auto& [tag, sizeTag] : {std::pair{DT_INIT_ARRAY, DT_INIT_ARRAYSZ}, std::pair{DT_FINI_ARRAY, DT_FINI_ARRAYSZ},
                                           std::pair{DT_PREINIT_ARRAY, DT_PREINIT_ARRAYSZ}}) {
            const uint64_t start = dyn(tag).value_or(0);
            if (dyn(tag) && address >= start && address - start < dyn(sizeTag).value_or(0)) return true;
        }
        return false;
    }

    // Every relocation writes inside the mapped segments, with a type the loader knows
    // and a symbol of the table. The relative ones that fill the initialiser and
    // finaliser arrays are kept for checkInitAndFini.
    void checkRelocations()
    {
        for (const auto& [tag, sizeTag, name] : {std::tuple{DT_RELA, DT_RELASZ, "its relocations (DT_RELA)"},
                                                  std::tuple{DT_JMPREL, DT_PLTRELSZ, "its PLT relocations (DT_JMPREL)"}}) {
            if (!dyn(tag)) continue;
            const bool rela = tag == DT_RELA || dyn(DT_PLTREL).value_or(DT_RELA) == DT_RELA;
            const uint64_t entry = rela ? sizeof(ElfW(Rela)) : sizeof(ElfW(Rel));
            const uint64_t count = dyn(sizeTag).value_or(0) / entry;
            if (count > kMaxRelocations) damaged(fmt::format("{} count {} entries", name, count));
            const uint64_t at = tableOffset(tag, count * entry, name);
            constexpr uint64_t kBatch = 4096;  // read in batches: memory stays bounded
            for (uint64_t first = 0; first < count; first += kBatch) {
                const uint64_t n = std::min(kBatch, count - first);
                std::vector<ElfW(Rela)> batch(n);
                if (rela) {
                    batch = readArray<ElfW(Rela)>(at + first * entry, n, name);
                } else {
                    const std::vector<ElfW(Rel)> rels = readArray<ElfW(Rel)>(at + first * entry, n, name);
                    for (uint64_t i = 0; i < n; ++i) batch[i] = {rels[i].r_offset, rels[i].r_info, 0};
                }
                for (const ElfW(Rela)& r : batch) {
                    checkRelocation(r.r_offset, relocationType(r.r_info), relocationSymbol(r.r_info), name);
                    if (inInitOrFiniArray(r.r_offset)) {
                        const bool relative = isRelative(relocationType(r.r_info));
                        initFiniRelocations_.push_back({r.r_offset, relative && rela ? std::optional<int64_t>(r.r_addend)
                                                                                     : std::nullopt, relative});
                    }
                }
            }
        }
    }

    // The functions the loader calls when it loads the library and at exit: each entry of
    // the arrays (the value the loader's relative relocation writes there, or the one in
    // the file) must be code.
    void checkInitAndFini()
    {
        for (const auto& [tag, sizeTag, name] : {std::tuple{DT_INIT_ARRAY, DT_INIT_ARRAYSZ, "initialiser"},
                                                  std::tuple{DT_FINI_ARRAY, DT_FINI_ARRAYSZ, "finaliser"},
                                                  std::tuple{DT_PREINIT_ARRAY, DT_PREINIT_ARRAYSZ, "pre-initialiser"}}) {
            if (!dyn(tag)) continue;
            const uint64_t address = *dyn(tag);
            const uint64_t count = dyn(sizeTag).value_or(0) / sizeof(ElfW(Addr));
            const std::vector<ElfW(Addr)> slots = readArray<ElfW(Addr)>(tableOffset(tag, count * sizeof(ElfW(Addr)), name), count, name);
            for (uint64_t i = 0; i < count; ++i) {
                uint64_t function = slots[i];
                bool symbolic = false;  // bound to a symbol: checkSymbols checked a definition here
                for (const InitFiniRelocation& r : initFiniRelocations_) {
                    if (r.slot != address + i * sizeof(ElfW(Addr))) continue;
                    if (r.addend) function = uint64_t(*r.addend);
                    symbolic = !r.relative;
                }
                // The loader skips neither 0 nor -1 in these arrays (unlike .ctors): both crash.
                if (!symbolic && !executable(function)) {
                    damaged(fmt::format("its {} array's entry {} ({:#x}) points outside every executable segment", name, i, function));
                }
            }
        }
    }

    const fs::path& path_;
    const std::string who_;
    std::optional<io::RegularFile> file_;
    uint64_t size_ = 0;
    ElfW(Ehdr) header_{};
    std::vector<ElfW(Phdr)> loads_;
    std::optional<ElfW(Phdr)> dynamic_;
    std::vector<std::pair<size_t, ElfW(Phdr)>> others_;  // TLS and RELRO, with their index
    std::vector<ElfW(Dyn)> entries_;                     // up to DT_NULL
    uint64_t strtab_ = 0, symtab_ = 0, symbolCount_ = 0;  // file offsets; symbols the hash tables count
    uint64_t highestRelocationSymbol_ = 0;
    // The relocations that fill the initialiser and finaliser arrays: a relative one's
    // addend is the function (RELA); a symbolic one's is the symbol's.
    struct InitFiniRelocation {
        uint64_t slot;
        std::optional<int64_t> addend;
        bool relative;
    };
    std::vector<InitFiniRelocation> initFiniRelocations_;
};

} // namespace

void checkSharedLibraryFile(const fs::path& file, const std::string& who) { LibraryCheck(file, who).run(); }

} // namespace penumbra::plugin

#include "core/LibraryBuildId.h"

#include <elf.h>
#include <link.h>

#include <fmt/format.h>

#include <cstdint>
#include <cstring>

namespace penumbra::core {
namespace {

struct Search {
    uintptr_t address = 0;  // of a function of the engine library
    std::string id;
};

bool holds(const dl_phdr_info& object, uintptr_t address)
{
    for (int s = 0; s < object.dlpi_phnum; ++s) {
        const ElfW(Phdr)& segment = object.dlpi_phdr[s];
        const uintptr_t start = object.dlpi_addr + segment.p_vaddr;
        if (segment.p_type == PT_LOAD && address >= start && address - start < segment.p_memsz) return true;
    }
    return false;
}

// The NT_GNU_BUILD_ID note among one loaded object's PT_NOTE segments.
std::string buildIdOf(const dl_phdr_info& object)
{
    for (int s = 0; s < object.dlpi_phnum; ++s) {
        const ElfW(Phdr)& segment = object.dlpi_phdr[s];
        if (segment.p_type != PT_NOTE) continue;
        const auto* at = reinterpret_cast<const unsigned char*>(object.dlpi_addr + segment.p_vaddr);
        const unsigned char* end = at + segment.p_memsz;
        // Notes are 4-byte aligned: header, name (with its NUL), then the descriptor.
        const auto aligned = [](size_t n) { return (n + 3) & ~size_t(3); };
        while (at + sizeof(ElfW(Nhdr)) <= end) {
            ElfW(Nhdr) note;
            std::memcpy(&note, at, sizeof note);
            const unsigned char* name = at + sizeof note;
            const unsigned char* desc = name + aligned(note.n_namesz);
            if (desc + note.n_descsz > end) break;
            if (note.n_type == NT_GNU_BUILD_ID && note.n_namesz == 4 && std::memcmp(name, "GNU", 4) == 0) {
                std::string id;
                for (size_t i = 0; i < note.n_descsz; ++i) id += fmt::format("{:02x}", desc[i]);
                return id;
            }
            at = desc + aligned(note.n_descsz);
        }
    }
    return {};
}

std::string findEngineBuildId()
{
    Search search{reinterpret_cast<uintptr_t>(&engineBuildId), {}};
    dl_iterate_phdr(
        [](dl_phdr_info* object, size_t, void* data) {
            auto* s = static_cast<Search*>(data);
            if (!holds(*object, s->address)) return 0;
            s->id = buildIdOf(*object);
            return 1;
        },
        &search);
    return search.id;
}

} // namespace

const std::string& engineBuildId()
{
    static const std::string id = findEngineBuildId();
    return id;
}

} // namespace penumbra::core

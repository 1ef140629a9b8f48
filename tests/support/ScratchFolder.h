#pragma once
// A folder of the running test's own under the temporary directory (a fixture's
// WithScratchFolder, or a ScratchFolder a test body holds), and hostile input written into
// it: what the tests of file handling share.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>

namespace penumbra::test {

// temp/penumbra_<prefix>_<pid>_<test name>, created (and emptied first, should a killed
// run have left it): one per test and process, so parallel tests never share one. The
// caller removes it (std::filesystem::remove_all) in its TearDown. A parameterised test's
// name ("Case/3") is one folder too: its '/' becomes '_'.
inline std::filesystem::path makeScratchFolder(std::string_view prefix)
{
    std::string name = fmt::format("penumbra_{}_{}_{}", prefix, ::getpid(), ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::replace(name.begin(), name.end(), '/', '_');
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

// A scratch folder (makeScratchFolder) that a test body holds, removed when it goes out of
// scope, however the test ends: for a test without a fixture's folder.
class ScratchFolder {
public:
    explicit ScratchFolder(std::string_view prefix) : path(makeScratchFolder(prefix)) {}
    ~ScratchFolder()
    {
        std::error_code ec;
        std::filesystem::remove_all(path, ec);
    }
    ScratchFolder(const ScratchFolder&) = delete;
    ScratchFolder& operator=(const ScratchFolder&) = delete;

    const std::filesystem::path path;
};

// A test with a scratch folder of its own (`dir`, makeScratchFolder named after the test
// suite), removed after the test. `Base` is the fixture it extends (a GPU test, ...).
template <class Base = ::testing::Test>
class WithScratchFolder : public Base {
protected:
    void SetUp() override
    {
        Base::SetUp();
        dir = makeScratchFolder(::testing::UnitTest::GetInstance()->current_test_info()->test_suite_name());
    }
    void TearDown() override
    {
        std::filesystem::remove_all(dir);
        Base::TearDown();
    }

    std::filesystem::path dir;
};
using ScratchFolderTest = WithScratchFolder<>;

// JSON text: `levels` nested objects ({"a": ...}) or arrays ([...]) around the number 1,
// as deep as a hostile file nests them.
inline std::string nestedJson(int levels, bool arrays)
{
    std::string open, close;
    for (int i = 0; i < levels; ++i) {
        open += arrays ? "[" : "{\"a\":";
        close += arrays ? "]" : "}";
    }
    return open + "1" + close;
}

// A file's whole content ("" when it cannot be read).
inline std::string readFile(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

// The names in a folder: what a test of outputs checks is all that is left there.
inline std::set<std::string> entryNames(const std::filesystem::path& dir)
{
    std::set<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir)) names.insert(e.path().filename().string());
    return names;
}

} // namespace penumbra::test

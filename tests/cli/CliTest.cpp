#include "CliTest.h"

#include <fmt/format.h>
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>

namespace fs = std::filesystem;

namespace penumbra::test {

std::vector<int> Rgba8Image::at(int x, int y) const
{
    const size_t i = 4 * (size_t(y) * size_t(width) + size_t(x));
    return {rgba[i], rgba[i + 1], rgba[i + 2], rgba[i + 3]};
}

Rgba8Image readImage(const fs::path& file)
{
    Rgba8Image image;
    int channels = 0;
    unsigned char* data = stbi_load(file.c_str(), &image.width, &image.height, &channels, 4);
    if (!data) return image;
    image.rgba.assign(data, data + size_t(image.width) * size_t(image.height) * 4);
    stbi_image_free(data);
    return image;
}

std::string testPlugins() { return testPluginDir().string(); }

std::string shadowedPlugins() { return shadowedTestPluginDir().string(); }

std::string pluginPath() { return fmt::format("PENUMBRA_PLUGIN_PATH='{}:{}'", testPlugins(), shadowedPlugins()); }

std::string testGoodConfig(const std::string& shadow, const std::string& extra)
{
    return fmt::format(R"({{"camera": {{"position": [0, 5, 10], "target": [0, 0, 0]}},
        "scene": {{"generator": "box-grid", "params": {{"rows": 1, "columns": 1}}}},
        "lights": [{{"name": "key", "type": "point", "position": [0, 4, 0], "shadow": {{"technique": "testgood"{}}}}},
                   {{"name": "fill", "type": "point", "position": [2, 4, 0], "shadow": {{"technique": "nosuch", "required": false}}}}]{}}})",
                       shadow, extra);
}

CliResult Cli::run(const std::string& args, const std::string& env) const
{
    const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
    const std::string cmd = fmt::format("{} '{}' {} > '{}' 2> '{}' < /dev/null", env, penumbraExecutable().string(), args,
                                        out.string(), err.string());
    const int status = std::system(cmd.c_str());
    CliResult r;
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    r.out = readFile(out);
    r.err = readFile(err);
    return r;
}

std::string Cli::config(const std::string& name) const { return fmt::format("'{}/config/{}'", sourceDir().string(), name); }

std::string Cli::data(const std::string& name) const { return fmt::format("'{}/{}'", testDataDir().string(), name); }

void Cli::expectBadOutputFoldersRefused(const std::string& command, const std::string& env) const
{
    std::ofstream(dir / "file") << "x";
    CliResult r = run(fmt::format("{} -o '{}'", command, (dir / "file").string()), env);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("/file: exists and is not a folder"), std::string::npos) << r.err;
    EXPECT_EQ(readFile(dir / "file"), "x");
    r = run(fmt::format("{} -o '{}/a/b'", command, dir.string()), env);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("/a/b: cannot create the folder: '"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "a"));
}

} // namespace penumbra::test

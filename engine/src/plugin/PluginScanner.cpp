#include "plugin/PluginScanner.h"

#include "penumbra/plugin/PluginRegistry.h"

#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <optional>
#include <thread>

extern char** environ;

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace penumbra::plugin {
namespace {

// The scanner prints one plugin's description: far below these. Beyond them it is not the
// scanner talking, and reading on would let a plugin fill the engine's memory.
constexpr size_t kMaxOutputBytes = size_t(1) << 20;
constexpr size_t kMaxErrorBytes = size_t(16) << 10;

class Pipe {
public:
    Pipe()
    {
        if (pipe2(fds_.data(), O_CLOEXEC) != 0) fds_ = {-1, -1};
    }
    ~Pipe()
    {
        for (int fd : fds_)
            if (fd >= 0) close(fd);
    }
    Pipe(const Pipe&) = delete;
    Pipe& operator=(const Pipe&) = delete;
    bool ok() const { return fds_[0] >= 0; }
    int reader() const { return fds_[0]; }
    int writer() const { return fds_[1]; }
    void closeWriter()
    {
        close(fds_[1]);
        fds_[1] = -1;
    }

private:
    std::array<int, 2> fds_{};
};

// "SIGSEGV (Segmentation fault)".
std::string signalName(int signal)
{
    const char* abbreviation = sigabbrev_np(signal);
    const char* description = strsignal(signal);
    return abbreviation ? fmt::format("SIG{} ({})", abbreviation, description ? description : "?")
                        : fmt::format("signal {}", signal);
}

// The last non-empty line of what the child wrote to stderr: the loader's own words
// ("Inconsistency detected by ld.so: ...") or an abort message.
std::string lastWords(const std::string& err)
{
    std::string_view text = err;
    while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.remove_suffix(1);
    const size_t start = text.find_last_of('\n');
    const std::string_view line = start == std::string_view::npos ? text : text.substr(start + 1);
    return line.empty() ? std::string() : fmt::format(" (it said: {})", core::shortText(line));
}

struct ChildResult {
    std::string out, err;
    std::optional<int> status;  // waitpid's; none when it was killed for the timeout
    bool outputTooLong = false;
};

ChildResult runChild(pid_t pid, Pipe& out, Pipe& err, Clock::time_point deadline)
{
    ChildResult result;
    std::array<pollfd, 2> fds{pollfd{out.reader(), POLLIN, 0}, pollfd{err.reader(), POLLIN, 0}};
    std::array<char, 4096> buffer{};
    bool killed = false;
    const auto kill9 = [&] {
        if (!killed) kill(pid, SIGKILL);
        killed = true;
    };
    while (fds[0].fd >= 0 || fds[1].fd >= 0) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
        if (left <= 0) {
            kill9();
            break;
        }
        const int ready = poll(fds.data(), fds.size(), int(std::min<long long>(left, 1000)));
        if (ready < 0 && errno != EINTR) {
            kill9();
            break;
        }
        for (size_t i = 0; i < fds.size(); ++i) {
            if (fds[i].fd < 0 || fds[i].revents == 0) continue;
            const ssize_t n = read(fds[i].fd, buffer.data(), buffer.size());
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                fds[i].fd = -1;
                continue;
            }
            std::string& into = i == 0 ? result.out : result.err;
            const size_t bound = i == 0 ? kMaxOutputBytes : kMaxErrorBytes;
            into.append(buffer.data(), std::min(size_t(n), bound - std::min(bound, into.size())));
            if (i == 0 && result.out.size() >= kMaxOutputBytes) {
                result.outputTooLong = true;
                kill9();
                fds[0].fd = fds[1].fd = -1;
            }
        }
    }
    // Both pipes closed: the child is exiting, or closed them and lives on until the deadline.
    int status = 0;
    while (true) {
        const pid_t done = waitpid(pid, &status, killed ? 0 : WNOHANG);
        if (done == pid) break;
        if (done < 0 && errno != EINTR) return result;
        if (!killed && Clock::now() >= deadline) kill9();
        else if (!killed) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    if (!killed) result.status = status;
    return result;
}

} // namespace

PluginMetadata scanInChildProcess(const fs::path& scanner, const fs::path& file, const std::string& who,
                                  std::chrono::milliseconds timeout)
{
    const auto failed = [&](const std::string& what) {
        return PluginError(PluginErrorKind::ScanFailed, fmt::format("{}: {}", who, what), file);
    };
    Pipe out, err;
    if (!out.ok() || !err.ok()) throw failed(fmt::format("cannot be scanned: no pipe to the plugin scanner ({})", std::strerror(errno)));
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, out.writer(), STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&actions, err.writer(), STDERR_FILENO);
    // Absolute: the shader folder it resolves beside the file must hold from any folder
    // (the cache hands it to later runs).
    std::error_code ec;
    const std::string scannerPath = scanner.string(), filePath = fs::absolute(file, ec).string();
    char* argv[] = {const_cast<char*>(scannerPath.c_str()), const_cast<char*>(filePath.c_str()), const_cast<char*>(who.c_str()),
                    nullptr};
    pid_t pid = -1;
    const int spawned = posix_spawn(&pid, scannerPath.c_str(), &actions, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    if (spawned != 0) {
        throw failed(fmt::format("cannot be scanned: the plugin scanner {} cannot be started ({}); reinstall Penumbra, or "
                                 "set PENUMBRA_PLUGIN_SCANNER to the penumbra-plugin-scanner executable",
                                 scannerPath, std::strerror(spawned)));
    }
    out.closeWriter();
    err.closeWriter();
    const ChildResult child = runChild(pid, out, err, Clock::now() + timeout);

    if (child.outputTooLong) throw failed(fmt::format("the plugin scanner printed more than {} bytes while loading it", kMaxOutputBytes));
    if (!child.status) {
        throw failed(fmt::format("the plugin scanner did not finish loading it within {} s and was stopped; a constructor "
                                 "or the entry point of the plugin hangs{}",
                                 double(timeout.count()) / 1000.0, lastWords(child.err)));
    }
    if (WIFSIGNALED(*child.status)) {
        throw failed(fmt::format("the plugin scanner died of {} while loading it{}; the file is damaged, or the plugin's "
                                 "constructors or entry point crash: rebuild the plugin",
                                 signalName(WTERMSIG(*child.status)), lastWords(child.err)));
    }
    if (!WIFEXITED(*child.status) || WEXITSTATUS(*child.status) != 0) {
        throw failed(fmt::format("the plugin scanner exited with status {} while loading it{}; the file is damaged, or the "
                                 "plugin ends the process: rebuild the plugin",
                                 WEXITSTATUS(*child.status), lastWords(child.err)));
    }
    nlohmann::json doc = nlohmann::json::parse(child.out, nullptr, false);
    if (doc.is_object() && doc.contains("plugin")) return PluginMetadata::fromJson(doc["plugin"], file);
    if (doc.is_object() && doc.contains("error") && doc["error"].is_object()) {
        const nlohmann::json& e = doc["error"];
        const std::optional<PluginErrorKind> kind =
            e.contains("kind") && e["kind"].is_string() ? pluginErrorKindNamed(e["kind"].get<std::string>()) : std::nullopt;
        if (kind && e.contains("message") && e["message"].is_string()) throw PluginError(*kind, e["message"].get<std::string>(), file);
    }
    throw failed(fmt::format("the plugin scanner's output is unreadable: {}{}", core::shortText(child.out), lastWords(child.err)));
}

} // namespace penumbra::plugin

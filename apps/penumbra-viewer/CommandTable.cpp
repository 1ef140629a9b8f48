#include "CommandTable.h"

#include "penumbra/core/ClosestMatch.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <sstream>

namespace penumbra::viewer {
namespace {

// How many arguments a form takes: its words, of which those in [brackets] may be left out.
struct Arity {
    size_t required = 0, optional = 0;
};

Arity arityOf(const std::string& form)
{
    Arity arity;
    std::istringstream words(form);
    for (std::string word; words >> word;) ++(word.front() == '[' ? arity.optional : arity.required);
    return arity;
}

bool takes(const CommandSpec& spec, size_t arguments)
{
    if (spec.forms.empty()) return arguments == 0;
    return std::any_of(spec.forms.begin(), spec.forms.end(), [&](const std::string& form) {
        const Arity a = arityOf(form);
        return arguments >= a.required && arguments <= a.required + a.optional;
    });
}

// A cell of a Markdown table: a `|` would end it.
std::string markdownCell(const std::string& text)
{
    std::string cell;
    for (char c : text) {
        if (c == '|') cell += '\\';
        cell += c;
    }
    return cell;
}

} // namespace

CommandList::CommandList(std::vector<CommandSpec> specs) : specs_(std::move(specs))
{
    for (const CommandSpec& spec : specs_) {
        if (std::find(verbs_.begin(), verbs_.end(), spec.verb) != verbs_.end()) {
            throw Error(fmt::format("the command \"{}\" is listed twice", spec.verb));
        }
        verbs_.push_back(spec.verb);
    }
}

size_t CommandList::check(const ScriptCommand& command) const
{
    const std::string& verb = command.words.at(0);
    const auto found = std::find(verbs_.begin(), verbs_.end(), verb);
    if (found == verbs_.end()) {
        const std::string best = core::closestMatch(verb, verbs_);
        throw Error(fmt::format("{}: unknown command \"{}\"{}; the commands are {}", command.where, core::shortText(verb),
                                best.empty() ? "" : fmt::format(" (did you mean \"{}\"?)", best), fmt::join(verbs_, ", ")));
    }
    const size_t index = size_t(found - verbs_.begin());
    const size_t arguments = command.words.size() - 1;
    if (!takes(specs_[index], arguments)) {
        throw Error(fmt::format("{}: {}: expected {}, got {} argument{}", command.where, verb, usage(specs_[index]), arguments,
                                arguments == 1 ? "" : "s"));
    }
    return index;
}

std::string CommandList::usage(const CommandSpec& spec)
{
    if (spec.forms.empty()) return fmt::format("`{}` with no arguments", spec.verb);
    std::vector<std::string> forms;
    for (const std::string& form : spec.forms) forms.push_back(fmt::format("`{} {}`", spec.verb, form));
    return fmt::format("{}", fmt::join(forms, " or "));
}

std::string CommandList::markdown() const
{
    std::string table = "| command | what it does |\n|---|---|\n";
    for (const CommandSpec& spec : specs_) {
        std::vector<std::string> forms;
        if (spec.forms.empty()) forms.push_back(fmt::format("`{}`", spec.verb));
        for (const std::string& form : spec.forms) forms.push_back(fmt::format("`{} {}`", spec.verb, form));
        table += fmt::format("| {} | {} |\n", markdownCell(fmt::format("{}", fmt::join(forms, ", "))), markdownCell(spec.help));
    }
    return table;
}

void throwCommandError(const ScriptCommand& command, const std::string& what)
{
    throw Error(fmt::format("{}: {}: {}", command.where, command.words.at(0), what));
}

} // namespace penumbra::viewer

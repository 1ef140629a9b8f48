#pragma once
// A script's commands as one table: each row a verb, its argument forms, its help and its
// handler. The dispatcher looks verbs up in it, the unknown-verb and argument-count errors
// quote it, and `penumbra-viewer --list-commands` prints it as docs/viewer.md's command
// table (a test holds the two equal). The viewer's own table is Viewer::commands()
// (ViewerCommands.cpp).
#include "Script.h"

#include <cstddef>
#include <initializer_list>
#include <string>
#include <vector>

namespace penumbra::viewer {

struct CommandSpec {
    std::string verb;
    // The argument forms, each as the user writes it after the verb: upper-case words are
    // values, `a|b` a choice, `[WORD]` optional ("LIGHT intensity VALUE"). No form: the
    // verb takes no arguments.
    std::vector<std::string> forms;
    std::string help;  // Markdown, one line: docs/viewer.md's "what it does"
};

// The table's specs without the handlers: what checking and listing need.
class CommandList {
public:
    explicit CommandList(std::vector<CommandSpec> specs);  // throws Error on a verb listed twice

    // The index of `command`'s verb, once its argument count fits one of the verb's forms.
    // Throws Error naming command.where: an unknown verb (with every verb, and the closest
    // one when it is a likely typo), or a count no form takes (with the forms).
    size_t check(const ScriptCommand& command) const;
    // "`light LIGHT intensity VALUE` or `light ...`": the verb's forms for a message.
    static std::string usage(const CommandSpec& spec);
    // docs/viewer.md's table: a header and one row per verb, in the table's order, `|`
    // inside a cell escaped as Markdown requires.
    std::string markdown() const;
    const std::vector<CommandSpec>& specs() const { return specs_; }

private:
    std::vector<CommandSpec> specs_;
    std::vector<std::string> verbs_;
};

// The table with its handlers: `Target` is what the commands act on (the Viewer).
template <class Target>
class CommandTable {
public:
    using Handler = void (*)(Target& target, const ScriptCommand& command);
    struct Row {
        CommandSpec spec;
        Handler run;
    };

    CommandTable(std::initializer_list<Row> rows) : list_(specsOf(rows))
    {
        for (const Row& row : rows) handlers_.push_back(row.run);
    }

    // Checks the command (CommandList::check) and runs its handler.
    void run(Target& target, const ScriptCommand& command) const { handlers_[list_.check(command)](target, command); }
    const CommandList& list() const { return list_; }

private:
    static std::vector<CommandSpec> specsOf(std::initializer_list<Row> rows)
    {
        std::vector<CommandSpec> specs;
        for (const Row& row : rows) specs.push_back(row.spec);
        return specs;
    }

    CommandList list_;
    std::vector<Handler> handlers_;
};

// "`where`: `verb`: `what`" for a handler's error about its arguments' values.
[[noreturn]] void throwCommandError(const ScriptCommand& command, const std::string& what);

} // namespace penumbra::viewer

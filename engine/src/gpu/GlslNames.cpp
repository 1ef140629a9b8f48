#include "penumbra/gpu/GlslNames.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::gpu {
namespace {

enum class Kind { Identifier, Space, Other };

struct Token {
    Kind kind;
    std::string_view text;
};

bool identifierStart(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
bool identifierChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }
bool digit(char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; }

// Identifiers, numbers (never renamed: "1e5" is not the name "e5"), white space, and
// every other character as a token of its own (operators need no more here).
std::vector<Token> tokenize(std::string_view s)
{
    std::vector<Token> tokens;
    size_t i = 0;
    while (i < s.size()) {
        const size_t start = i;
        const char c = s[i];
        Kind kind = Kind::Other;
        if (std::isspace(static_cast<unsigned char>(c))) {
            while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
            kind = Kind::Space;
        } else if (identifierStart(c)) {
            while (i < s.size() && identifierChar(s[i])) ++i;
            kind = Kind::Identifier;
        } else if (digit(c) || (c == '.' && i + 1 < s.size() && digit(s[i + 1]))) {
            ++i;
            while (i < s.size() &&
                   (identifierChar(s[i]) || s[i] == '.' ||
                    ((s[i] == '+' || s[i] == '-') && (s[i - 1] == 'e' || s[i - 1] == 'E')))) {
                ++i;
            }
        } else {
            ++i;
        }
        tokens.push_back({kind, s.substr(start, i - start)});
    }
    return tokens;
}

// Words that stand where a declarator could ("layout(...) in;", "precision highp float;")
// and are never a unit's own name.
bool reserved(std::string_view word)
{
    static const std::set<std::string_view> kWords = {
        "in",       "out",      "inout",     "uniform",  "buffer",   "shared",   "const",    "struct",
        "layout",   "readonly", "writeonly", "coherent", "volatile", "restrict", "flat",     "smooth",
        "highp",    "mediump",  "lowp",      "precision", "invariant", "precise", "centroid", "sample",
        "patch",    "noperspective", "float", "int",     "uint",     "bool",     "double",   "void"};
    return kWords.count(word) != 0 || word.rfind("gl_", 0) == 0;
}

bool is(const Token* t, std::string_view text) { return t && t->text == text; }

// The declarators of one file-scope statement without braces: a function's prototype,
// or variables ("const float a = f(1.0), b[2];", "layout(...) uniform sampler2D m;").
void declaredBy(const std::vector<const Token*>& statement, std::set<std::string>& names)
{
    // A prototype: an identifier, other than layout, directly before a '(' that comes
    // before any '='.
    for (size_t i = 1; i < statement.size(); ++i) {
        if (is(statement[i], "=")) break;
        if (is(statement[i], "(")) {
            const Token* before = statement[i - 1];
            if (before->kind == Kind::Identifier && before->text != "layout") {
                names.insert(std::string(before->text));
                return;
            }
        }
    }
    // Variables: in each comma-separated declarator, the last identifier outside
    // brackets before its '='.
    int depth = 0;
    bool initializer = false;
    std::string_view last;
    const auto flush = [&] {
        if (!last.empty() && !reserved(last)) names.insert(std::string(last));
        last = {};
    };
    for (const Token* t : statement) {
        if (is(t, "(") || is(t, "[")) ++depth;
        else if (is(t, ")") || is(t, "]")) --depth;
        else if (depth == 0 && is(t, "=")) initializer = true;
        else if (depth == 0 && is(t, ",")) {
            flush();
            initializer = false;
        } else if (depth == 0 && !initializer && t->kind == Kind::Identifier) {
            last = t->text;
        }
    }
    flush();
}

// Whether a statement has an '=' outside parentheses: "x = {...}" is an initializer list,
// "layout(binding = 3) buffer B {...}" a block.
bool initializes(const std::vector<const Token*>& statement)
{
    int depth = 0;
    for (const Token* t : statement) {
        if (is(t, "(") || is(t, "[")) ++depth;
        else if (is(t, ")") || is(t, "]")) --depth;
        else if (depth == 0 && is(t, "=")) return true;
    }
    return false;
}

// The index of the '}' that closes the '{' at `open`.
size_t matchingBrace(const std::vector<Token>& tokens, size_t open)
{
    int depth = 0;
    for (size_t i = open; i < tokens.size(); ++i) {
        if (tokens[i].text == "{") ++depth;
        if (tokens[i].text == "}" && --depth == 0) return i;
    }
    throw Error("GLSL unit: a '{' is never closed");
}

// Lines that start with '#' are directives: dropped, #extension kept aside.
std::string withoutDirectives(std::string_view glsl, std::vector<std::string>& extensions)
{
    std::string text;
    size_t at = 0;
    while (at < glsl.size()) {
        size_t end = glsl.find('\n', at);
        if (end == std::string_view::npos) end = glsl.size();
        const std::string_view line = glsl.substr(at, end - at);
        const size_t first = line.find_first_not_of(" \t\r");
        if (first != std::string_view::npos && line[first] == '#') {
            if (line.compare(first, 10, "#extension") == 0) extensions.emplace_back(line.substr(first));
            text += '\n';  // keeps the unit's line count
        } else {
            text.append(line).append("\n");
        }
        at = end + 1;
    }
    return text;
}

} // namespace

PrefixedUnit prefixTopLevelNames(std::string_view glsl, std::string_view prefix)
{
    PrefixedUnit unit;
    const std::string text = withoutDirectives(glsl, unit.extensions);
    const std::vector<Token> tokens = tokenize(text);

    // Pass 1: what the unit declares at file scope, and which token ranges are member
    // lists (a struct's or a block's braces), where the declarators are member names.
    std::set<std::string> names;
    std::vector<bool> member(tokens.size(), false);
    std::vector<const Token*> statement;
    for (size_t i = 0; i < tokens.size(); ++i) {
        const Token& t = tokens[i];
        if (t.kind == Kind::Space) continue;
        if (t.text == "{") {
            const size_t close = matchingBrace(tokens, i);
            const Token* before = statement.empty() ? nullptr : statement.back();
            if (initializes(statement)) {
                // an initializer list: "const float a[2] = {1.0, 2.0};"
            } else if (is(before, ")")) {  // a function's body
                declaredBy(statement, names);
                statement.clear();
            } else {  // struct Name { ... } or a block: qualifiers Name { ... }
                if (before && before->kind == Kind::Identifier && !reserved(before->text))
                    names.insert(std::string(before->text));
                std::fill(member.begin() + std::ptrdiff_t(i), member.begin() + std::ptrdiff_t(close) + 1, true);
                statement.clear();  // what follows "}" names instances: "} shadowMapBuffer;"
            }
            i = close;
            continue;
        }
        if (t.text == "}") throw Error("GLSL unit: a '}' closes nothing");
        if (t.text == ";") {
            declaredBy(statement, names);
            statement.clear();
            continue;
        }
        statement.push_back(&t);
    }

    // Pass 2: every use, except a member after '.', and a member's own declarator.
    const auto nextSolid = [&](size_t i) -> const Token* {
        for (size_t j = i + 1; j < tokens.size(); ++j)
            if (tokens[j].kind != Kind::Space) return &tokens[j];
        return nullptr;
    };
    const Token* previous = nullptr;
    for (size_t i = 0; i < tokens.size(); ++i) {
        const Token& t = tokens[i];
        bool rename = t.kind == Kind::Identifier && names.count(std::string(t.text)) && !is(previous, ".");
        if (rename && member[i]) {
            const Token* next = nextSolid(i);
            rename = !(is(next, ";") || is(next, ",") || is(next, "["));
        }
        if (rename) unit.text.append(prefix);
        unit.text.append(t.text);
        if (t.kind != Kind::Space) previous = &t;
    }
    unit.names.assign(names.begin(), names.end());
    return unit;
}

} // namespace penumbra::gpu

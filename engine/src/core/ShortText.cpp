#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

using nlohmann::json;

namespace penumbra::core {
namespace {

// How a long value is cut: this much of its start, this much of its end.
constexpr size_t kHeadChars = 80, kTailChars = 60;

bool continuationByte(char c) { return (static_cast<unsigned char>(c) & 0xC0) == 0x80; }

// The first `bytes` bytes of `text`, moved back to a character boundary.
std::string_view head(std::string_view text, size_t bytes)
{
    size_t end = std::min(bytes, text.size());
    while (end > 0 && end < text.size() && continuationByte(text[end])) --end;
    return text.substr(0, end);
}

// The last `bytes` bytes of `text`, moved forward to a character boundary.
std::string_view tail(std::string_view text, size_t bytes)
{
    size_t start = text.size() - std::min(bytes, text.size());
    while (start < text.size() && continuationByte(text[start])) ++start;
    return text.substr(start);
}

size_t characterCount(std::string_view text)
{
    return size_t(std::count_if(text.begin(), text.end(), [](char c) { return !continuationByte(c); }));
}

// `text` escaped as the inside of a JSON string (no quotes); bytes that are not UTF-8
// become U+FFFD.
std::string escaped(std::string_view text)
{
    const std::string quoted = json(std::string(text)).dump(-1, ' ', false, json::error_handler_t::replace);
    return quoted.substr(1, quoted.size() - 2);
}

// Writes JSON text until `budget` characters are out, then closes what is open with "…".
class BoundedJsonText {
public:
    explicit BoundedJsonText(size_t budget) : budget_(budget) {}

    void write(const json& value)
    {
        if (full()) {
            cut();
            return;
        }
        switch (value.type()) {
        case json::value_t::string: writeString(value.get_ref<const std::string&>()); break;
        case json::value_t::array:
            text_ += '[';
            for (size_t i = 0; i < value.size(); ++i) {
                if (!separate(i)) break;
                write(value[i]);
            }
            text_ += ']';
            break;
        case json::value_t::object: {
            text_ += '{';
            size_t i = 0;
            for (auto it = value.begin(); it != value.end(); ++it, ++i) {
                if (!separate(i)) break;
                writeString(it.key());
                text_ += ':';
                write(it.value());
            }
            text_ += '}';
            break;
        }
        case json::value_t::number_float:
            if (!std::isfinite(value.get<double>())) {
                text_ += fmt::format("{}", value.get<double>());
                break;
            }
            [[fallthrough]];
        default: text_ += value.dump(); break;
        }
    }

    const std::string& text() const { return text_; }
    bool wasCut() const { return wasCut_; }

private:
    bool full() const { return text_.size() >= budget_; }
    void cut()
    {
        text_ += "…";
        wasCut_ = true;
    }
    // Before element `i`: the separator, or "…" and false when the budget is spent.
    bool separate(size_t i)
    {
        if (i > 0) text_ += ',';
        if (!full()) return true;
        cut();
        return false;
    }
    void writeString(std::string_view s)
    {
        // Some of a string even where little budget is left: "ab…" says more than "…".
        const size_t room = std::max<size_t>(budget_ - std::min(budget_, text_.size()), 8);
        if (s.size() <= room) {
            text_ += fmt::format("\"{}\"", escaped(s));
            return;
        }
        text_ += fmt::format("\"{}…\"", escaped(head(s, room)));
        wasCut_ = true;
    }

    size_t budget_;
    std::string text_;
    bool wasCut_ = false;
};

} // namespace

std::string shortText(std::string_view text)
{
    if (text.size() <= kShownChars) return std::string(text);
    return fmt::format("{}…{} ({} characters)", head(text, kHeadChars), tail(text, kTailChars), characterCount(text));
}

std::string shortJson(const json& value)
{
    if (value.is_string()) {
        const std::string& s = value.get_ref<const std::string&>();
        if (s.size() <= kShownChars) return fmt::format("\"{}\"", escaped(s));
        return fmt::format("\"{}…{}\" ({} characters)", escaped(head(s, kHeadChars)), escaped(tail(s, kTailChars)),
                           characterCount(s));
    }
    BoundedJsonText out(kShownChars);
    out.write(value);
    if (!out.wasCut()) return out.text();
    if (value.is_array()) return fmt::format("{} ({} elements)", out.text(), value.size());
    if (value.is_object()) return fmt::format("{} ({} keys)", out.text(), value.size());
    return out.text();
}

} // namespace penumbra::core

#include "config/ConfigJson.h"

#include "penumbra/config/Document.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

#include <string>
#include <utility>
#include <vector>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::config {
namespace {

// nlohmann's SAX interface: each event places a value into the container that is open,
// or opens one. A container being filled never moves: values go into it only, and it
// grows its parent only once, when it opens (the parent's element is then the newest).
class DocumentBuilder {
public:
    DocumentBuilder(const fs::path& file, ConfigJsonWork& work) : file_(file), work_(work) {}

    json take() { return std::move(root_); }

    // The JSON pointer of the value being read.
    std::string pointer() const
    {
        std::string out;
        for (size_t i = 0; i < open_.size(); ++i) {
            const Frame& f = open_[i];
            // An array's newest element is the one being read while a container inside it is open.
            const bool inner = i + 1 < open_.size();
            out += f.array ? fmt::format("/{}", f.container->size() - (inner ? 1 : 0)) : "/" + f.key;
        }
        return out.empty() ? "/" : out;
    }

    bool null() { return place(nullptr); }
    bool boolean(bool v) { return place(v); }
    bool number_integer(json::number_integer_t v) { return place(v); }
    bool number_unsigned(json::number_unsigned_t v) { return place(v); }
    bool number_float(json::number_float_t v, const json::string_t&) { return place(v); }
    bool string(json::string_t& v) { return place(std::move(v)); }
    bool binary(json::binary_t& v) { return place(json::binary(std::move(v))); }
    bool start_object(std::size_t) { return open(json::object(), false); }
    bool start_array(std::size_t) { return open(json::array(), true); }
    bool end_object() { return close(); }
    bool end_array() { return close(); }
    bool key(json::string_t& k)
    {
        count(1);
        open_.back().key = std::move(k);
        return true;
    }
    template <class Exception> bool parse_error(std::size_t, const std::string&, const Exception& e) { throw e; }

private:
    struct Frame {
        json* container = nullptr;
        bool array = false;
        std::string key;  // objects: the key of the value being read
    };

    void count(size_t steps)
    {
        ++work_.events;
        work_.steps += steps;
    }

    // Puts `value` where the parser is, returning where it went.
    json* put(json&& value)
    {
        if (open_.empty()) {
            root_ = std::move(value);
            return &root_;
        }
        Frame& f = open_.back();
        if (f.array) {
            json::array_t& array = f.container->get_ref<json::array_t&>();
            array.push_back(std::move(value));
            return &array.back();
        }
        // A key given twice keeps its last value, as nlohmann's own parser does.
        json& slot = (*f.container)[f.key];
        slot = std::move(value);
        return &slot;
    }

    template <class V> bool place(V&& v)
    {
        count(1);
        put(json(std::forward<V>(v)));
        return true;
    }

    bool open(json&& empty, bool array)
    {
        if (open_.size() >= size_t(kMaxConfigNesting)) {
            throw ConfigError(fmt::format("{}: {}: nested deeper than {} levels of objects and arrays (a config "
                                          "needs a handful)",
                                          displayPath(file_), core::shortText(pointer()), kMaxConfigNesting));
        }
        count(2);
        open_.push_back({put(std::move(empty)), array, {}});
        return true;
    }

    bool close()
    {
        count(1);
        open_.pop_back();
        return true;
    }

    const fs::path& file_;
    ConfigJsonWork& work_;
    json root_;
    std::vector<Frame> open_;
};

} // namespace

json parseConfigJson(std::istream& in, const fs::path& file, ConfigJsonWork* work)
{
    ConfigJsonWork ignored;
    DocumentBuilder builder(file, work ? *work : ignored);
    try {
        json::sax_parse(in, &builder);
        return builder.take();
    } catch (const json::parse_error& e) {
        // nlohmann's message carries line and column: "parse error at line 3, column 5: ...".
        std::string what = e.what();
        if (auto pos = what.find("parse error"); pos != std::string::npos) what = what.substr(pos);
        throw ConfigError(fmt::format("{}: malformed JSON: {}", displayPath(file), core::shortText(what)));
    } catch (const json::out_of_range& e) {
        // 406: "number overflow parsing '1e309'": a number no double holds.
        std::string what = e.what();
        if (auto pos = what.find("] "); pos != std::string::npos) what = what.substr(pos + 2);
        throw ConfigError(fmt::format("{}: {}: {} (a number must lie within a double's range, about ±1.8e308)",
                                      displayPath(file), core::shortText(builder.pointer()), core::shortText(what)));
    } catch (const json::exception& e) {
        throw ConfigError(fmt::format("{}: {}: cannot read the JSON: {}", displayPath(file), core::shortText(builder.pointer()),
                                      core::shortText(e.what())));
    }
}

} // namespace penumbra::config

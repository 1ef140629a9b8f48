// core::shortText and core::shortJson (penumbra/core/ShortText.h): what every message
// shows of a value the user gave.
#include "penumbra/core/ShortText.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

using nlohmann::json;
using penumbra::core::kShownChars;
using penumbra::core::shortJson;
using penumbra::core::shortText;

TEST(ShortText, KeepsShortTextAndShortensLongText)
{
    EXPECT_EQ(shortText("/lights/0/shadow"), "/lights/0/shadow");
    EXPECT_EQ(shortText(std::string(kShownChars, 'x')), std::string(kShownChars, 'x'));
    const std::string s = shortText(std::string(100, 'a') + std::string(100, 'b'));
    EXPECT_EQ(s, std::string(80, 'a') + "…" + std::string(60, 'b') + " (200 characters)");
}

TEST(ShortText, CutsBetweenUtf8CharactersAndCountsCharacters)
{
    // "é" is two bytes: 200 of them are 400 bytes; byte 80 starts a character, and so
    // does byte 340 (the tail's first): cut elsewhere, a half character would show.
    std::string text;
    for (int i = 0; i < 200; ++i) text += "é";
    const std::string s = shortText("x" + text);  // the head's byte 80 is now inside a character
    EXPECT_NE(s.find(" (201 characters)"), std::string::npos) << s;
    const std::string shown = s.substr(0, s.find(" ("));
    EXPECT_NO_THROW((void)json(shown).dump()) << "a cut inside a UTF-8 character: " << shown;
    EXPECT_LT(s.size(), 2 * kShownChars);
}

TEST(ShortJson, SmallValuesAreTheirJson)
{
    for (const json& v : {json(5), json(0.5), json(true), json(nullptr), json("pcss"), json::array({1, 2, 3}),
                          json{{"technique", "hard"}, {"pcf_kernel", 5}}}) {
        EXPECT_EQ(shortJson(v), v.dump());
    }
    EXPECT_EQ(shortJson(json("a\"b\n")), "\"a\\\"b\\n\"");
    EXPECT_EQ(shortJson(json(std::numeric_limits<double>::quiet_NaN())), "nan");
    EXPECT_EQ(shortJson(json(-std::numeric_limits<double>::infinity())), "-inf");
}

TEST(ShortJson, HugeValuesShowTheirStartAndSize)
{
    const size_t limit = 2 * kShownChars + 40;  // the budget, one element's overshoot and the size note
    const std::string megabyte(1 << 20, 'q');

    const std::string s = shortJson(json(megabyte));
    EXPECT_LT(s.size(), limit) << s;
    EXPECT_EQ(s.rfind("\"qqq", 0), 0u) << s;
    EXPECT_NE(s.find("…qqq"), std::string::npos) << s;
    EXPECT_TRUE(s.ends_with("qqq\" (1048576 characters)")) << s;

    json numbers = json::array();
    for (int i = 0; i < 1000000; ++i) numbers.push_back(i);
    const std::string a = shortJson(numbers);
    EXPECT_LT(a.size(), limit) << a;
    EXPECT_EQ(a.rfind("[0,1,2,", 0), 0u) << a;
    EXPECT_TRUE(a.ends_with(",…] (1000000 elements)")) << a;

    const std::string o = shortJson(json{{"a", megabyte}, {"b", 1}});
    EXPECT_LT(o.size(), limit) << o;
    EXPECT_EQ(o.rfind("{\"a\":\"qqq", 0), 0u) << o;
    EXPECT_NE(o.find("(2 keys)"), std::string::npos) << o;

    // Deep nesting ends at the budget too: each level costs at least one character.
    json deep = json::array();
    json* innermost = &deep;
    for (int i = 0; i < 10000; ++i) innermost = &innermost->emplace_back(json::array());
    EXPECT_LT(shortJson(deep).size(), 4 * kShownChars);
}

TEST(ShortJson, BytesThatAreNotUtf8AreShownNotThrown)
{
    // A --set value given as plain text can hold any bytes.
    const std::string s = shortJson(json(std::string("a\xff\xfe") + std::string(300, 'b')));
    EXPECT_NE(s.find("\xEF\xBF\xBD"), std::string::npos) << s;  // U+FFFD
    EXPECT_NE(s.find("(303 characters)"), std::string::npos) << s;  // a stray byte counts as one
}

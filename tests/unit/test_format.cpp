// Numbers in messages (eci/format.hpp): the shortest text that reads back as the same double, laid out as Python's
// repr(float) lays it out, so that the library, the CLI and Python quote a number alike
// (tests/python/test_cli_agreement.py sends the front ends the same numbers).
#include <gtest/gtest.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <eci/format.hpp>

TEST(Format, ShortestTextIsLaidOutAsPythonsRepr) {
    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<std::pair<double, std::string>> cases{
        {0.1, "0.1"},  // not 0.10000000000000001
        {0.0001, "0.0001"},
        {1e-05, "1e-05"},
        {-2.5e-7, "-2.5e-07"},
        {100.0, "100"},
        {3.0, "3"},
        {1e15, "1000000000000000"},
        {9999999999999998.0, "9999999999999998"},
        {1e16, "1e+16"},
        {1.0000000000000002e19, "1.0000000000000002e+19"},  // (std::to_chars alone: 10000000000000002048)
        {123456789012345.6, "123456789012345.6"},
        {5e-324, "5e-324"},
        {std::numeric_limits<double>::max(), "1.7976931348623157e+308"},
        {0.0, "0"},
        {-0.0, "-0"},
        {inf, "inf"},
        {-inf, "-inf"},
        {std::numeric_limits<double>::quiet_NaN(), "nan"},
    };
    for (const auto& [v, text] : cases) EXPECT_EQ(eci::shortest_text(v), text);
}

// Whatever the layout, the text reads back as the same double, and is no longer than std::to_chars's shortest
// digits need (random bit patterns, every magnitude).
TEST(Format, ShortestTextReadsBackAsTheSameDouble) {
    std::mt19937_64 bits(11);
    for (int i = 0; i < 100000; ++i) {
        const std::uint64_t b = bits();
        double v;
        std::memcpy(&v, &b, sizeof v);
        if (!std::isfinite(v)) continue;
        const std::string s = eci::shortest_text(v);
        double back = 0.0;
        const auto r = std::from_chars(s.data(), s.data() + s.size(), back);
        ASSERT_EQ(r.ptr, s.data() + s.size()) << s;
        ASSERT_EQ(std::memcmp(&back, &v, sizeof v), 0) << s;
        char plain[32];
        const auto p = std::to_chars(plain, plain + sizeof plain, v, std::chars_format::scientific);
        const std::string sci(plain, p.ptr);
        std::size_t digits = 0;
        for (char c : sci.substr(0, sci.find('e'))) digits += c >= '0' && c <= '9';
        std::size_t ours = 0;
        for (char c : s.substr(0, s.find('e'))) ours += c >= '0' && c <= '9';
        // positional text pads with zeros (1e15 -> 1000000000000000, 0.0001) but holds no more significant digits
        ASSERT_LE(digits, ours) << s;
        ASSERT_LE(ours, digits + 19) << s;
    }
}

TEST(Format, FullTextHasSeventeenSignificantDigits) {
    EXPECT_EQ(eci::full_text(0.1), "0.10000000000000001");
    EXPECT_EQ(eci::full_text(1.0), "1");
    EXPECT_EQ(eci::full_text(1.0 / 3.0), "0.33333333333333331");
    EXPECT_EQ(eci::full_text(1e-300), "1e-300");  // (trailing zeros dropped, as %.17g drops them)
}

// Numbers as eci quotes them in its messages, the same in the library, the CLI and Python: the shortest text that
// reads back as the same double (a rejected 1e-300 is not "0.000000", 0.1 is not "0.10000000000000001"), laid out
// as Python's repr(float) lays it out, so that a front end's message and Python's own agree; and 17 significant
// digits for values a run reports (times, the CSV).
#pragma once

#include <charconv>
#include <cmath>
#include <limits>
#include <string>
#include <string_view>

namespace eci {

/// The shortest decimal text that reads back as v, positional for 1e-4 <= |v| < 1e16 and scientific with an
/// exponent of two digits at least elsewhere, as Python's repr(float) without its trailing ".0": 0.0001, 1e-05,
/// 1000000000000000, 1e+16, 1.0000000000000002e+19, -0, inf, nan.
inline std::string shortest_text(double v) {
    if (std::isnan(v)) return "nan";
    if (std::isinf(v)) return v < 0 ? "-inf" : "inf";
    char buffer[32];
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::scientific);
    const std::string_view s(buffer, std::size_t(r.ptr - buffer));  // [-]d[.ddd]e(+|-)xx
    const std::size_t e = s.find('e');
    int exp = 0;
    std::from_chars(s.data() + e + (s[e + 1] == '+' ? 2 : 1), s.data() + s.size(), exp);
    if (exp < -4 || exp >= 16) return std::string(s);
    const bool negative = s[0] == '-';
    std::string digits;
    for (char c : s.substr(negative ? 1 : 0, e - (negative ? 1 : 0)))
        if (c != '.') digits += c;
    std::string out = negative ? "-" : "";
    if (exp < 0) {
        out.append("0.").append(std::size_t(-exp - 1), '0').append(digits);
    } else if (digits.size() <= std::size_t(exp) + 1) {
        out.append(digits).append(std::size_t(exp) + 1 - digits.size(), '0');
    } else {
        out.append(digits, 0, std::size_t(exp) + 1).append(".").append(digits, std::size_t(exp) + 1);
    }
    return out;
}

/// v with 17 significant digits in `buffer` (a run's times in its messages, the CLI's CSV: reads back as v).
inline std::string_view format_double(double v, char (&buffer)[32]) {
    if (std::isnan(v)) v = std::numeric_limits<double>::quiet_NaN();  // "nan": a NaN's sign means nothing
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, 17);
    return {buffer, static_cast<std::size_t>(r.ptr - buffer)};
}

/// v with 17 significant digits, as a string.
inline std::string full_text(double v) {
    char buffer[32];
    return std::string(format_double(v, buffer));
}

}  // namespace eci

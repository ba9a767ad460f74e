// Numbers in the library's error messages: the shortest text that reads back as the same double, so that a
// rejected 1e-300 is not reported as "0.000000".
#pragma once

#include <charconv>
#include <string>
#include <string_view>

namespace eci::detail {

/// The shortest decimal text of v that reads back as v.
inline std::string shortest_text(double v) {
    char buffer[32];
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v);
    return std::string(buffer, r.ptr);
}

/// v with 17 significant digits in `buffer` (the run's messages and the CLI's CSV: reads back as v).
inline std::string_view format_double(double v, char (&buffer)[32]) {
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, 17);
    return {buffer, static_cast<std::size_t>(r.ptr - buffer)};
}

/// v with 17 significant digits, as a string.
inline std::string full_text(double v) {
    char buffer[32];
    return std::string(format_double(v, buffer));
}

}  // namespace eci::detail

// Numbers in the library's error messages: the shortest text that reads back as the same double, so that a
// rejected 1e-300 is not reported as "0.000000".
#pragma once

#include <charconv>
#include <string>

namespace eci::detail {

/// The shortest decimal text of v that reads back as v.
inline std::string shortest_text(double v) {
    char buffer[32];
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v);
    return std::string(buffer, r.ptr);
}

}  // namespace eci::detail

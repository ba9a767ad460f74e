// The library's messages quote numbers with eci/format.hpp's functions (the front ends' too).
#pragma once

#include "../format.hpp"

namespace eci::detail {

using eci::format_double;
using eci::full_text;
using eci::shortest_text;

}  // namespace eci::detail

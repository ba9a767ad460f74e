// What a request costs in memory against what this machine has: the one guard every front end shows, so that a
// request that cannot fit is refused before any work with its size, not as std::bad_alloc (or the system's OOM
// killer) part-way through.
#pragma once

#include <cstdio>
#include <stdexcept>
#include <string>
#include <string_view>

#if __has_include(<unistd.h>)
#include <unistd.h>
#endif
#if __has_include(<sys/resource.h>)
#include <sys/resource.h>
#endif

namespace eci {

/// This machine's physical memory in bytes; 0 where it cannot be known (then nothing is refused).
inline double physical_memory() {
#if __has_include(<unistd.h>) && defined(_SC_PHYS_PAGES) && defined(_SC_PAGESIZE)
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
    if (pages > 0 && page > 0) return double(pages) * double(page);
#endif
    return 0.0;
}

/// `bytes` in GiB with three significant digits: "31.5 GiB".
inline std::string gib_text(double bytes) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3g GiB", bytes / double(1ull << 30));
    return text;
}

/// The address space this process may take (ulimit -v, RLIMIT_AS) in bytes; 0 where there is no such limit.
inline double address_space_limit() {
#if __has_include(<sys/resource.h>) && defined(RLIMIT_AS)
    rlimit r{};
    if (::getrlimit(RLIMIT_AS, &r) == 0 && r.rlim_cur != RLIM_INFINITY) return double(r.rlim_cur);
#endif
    return 0.0;
}

/// Throws std::invalid_argument "WHAT needs about X GiB of memory, more than this machine's Y GiB" when `bytes`
/// exceeds this machine's physical memory, or the address space the process may take (a request that fits is never
/// refused).
inline void check_fits_in_memory(double bytes, std::string_view what) {
    const double have = physical_memory();
    if (have > 0.0 && bytes > have)
        throw std::invalid_argument(std::string(what) + " needs about " + gib_text(bytes) +
                                    " of memory, more than this machine's " + gib_text(have));
    const double may = address_space_limit();
    if (may > 0.0 && bytes > may)
        throw std::invalid_argument(std::string(what) + " needs about " + gib_text(bytes) +
                                    " of memory, more than this process may take (ulimit -v: " + gib_text(may) + ")");
}

}  // namespace eci

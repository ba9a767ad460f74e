// Output plumbing of the CLI: temporary-then-rename files, full-precision numbers, JSON scalars, the progress
// bar and the interrupt flag. No numerics here.
#include "output.hpp"

#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <initializer_list>
#include <system_error>

#include <sys/stat.h>
#include <unistd.h>

namespace eci::cli {

namespace {

volatile std::sig_atomic_t interrupt_flag = 0;

extern "C" void on_interrupt(int) { interrupt_flag = 1; }

std::string errno_text() { return std::strerror(errno); }

// Built with append, not operator+ chains, which trip a false -Wrestrict in GCC 12's libstdc++.
std::string message(std::initializer_list<std::string_view> parts) {
    std::string s;
    for (std::string_view p : parts) s.append(p);
    return s;
}

}  // namespace

output_file::output_file(std::string path, std::string_view what) : path_(std::move(path)), what_(what) {
    if (path_ == "-") {
        to_stdout_ = true;
        file_ = stdout;
        return;
    }
    namespace fs = std::filesystem;
    const fs::path target(path_);
    std::error_code ec;
    if (fs::is_directory(target, ec)) throw bad_input(message({what_, " '", path_, "' is a directory"}));
    if (target.filename().empty()) throw bad_input(message({what_, " '", path_, "' names no file"}));
    // Same directory as the target, so the final rename cannot cross file systems.
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    std::string temp = (dir / message({".", target.filename().string(), ".eci-tmp-XXXXXX"})).string();
    const int fd = ::mkstemp(temp.data());
    if (fd < 0) throw bad_input(message({"cannot write ", what_, " '", path_, "': ", errno_text()}));
    temp_ = temp;
    // mkstemp makes the file private (0600); give it the permissions a plain fopen would.
    const mode_t mask = ::umask(0);
    ::umask(mask);
    ::fchmod(fd, 0666 & ~mask);
    file_ = ::fdopen(fd, "w");
    if (!file_) {
        ::close(fd);
        ::unlink(temp_.c_str());
        throw bad_input(message({"cannot write ", what_, " '", path_, "': ", errno_text()}));
    }
    static constexpr std::size_t buffer_size = 1 << 16;
    std::setvbuf(file_, nullptr, _IOFBF, buffer_size);
}

output_file::~output_file() {
    if (to_stdout_ || !file_) return;
    std::fclose(file_);
    ::unlink(temp_.c_str());
}

void output_file::commit() {
    if (!file_) return;
    if (to_stdout_) {
        if (std::fflush(stdout) != 0 || std::ferror(stdout))
            throw bad_input(message({"cannot write ", what_, " to standard output: ", errno_text()}));
        file_ = nullptr;
        return;
    }
    const bool write_failed = std::ferror(file_) != 0;
    const bool close_failed = std::fclose(file_) != 0;
    file_ = nullptr;
    if (write_failed || close_failed || std::rename(temp_.c_str(), path_.c_str()) != 0) {
        const std::string reason = errno_text();
        ::unlink(temp_.c_str());
        throw bad_input(message({"cannot write ", what_, " '", path_, "': ", reason}));
    }
}

std::string_view format_double(double v, char (&buffer)[32]) {
    const auto r = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, 17);
    return {buffer, static_cast<std::size_t>(r.ptr - buffer)};
}

void write_json_number(std::FILE* f, double v) {
    if (!std::isfinite(v)) {
        std::fputs("null", f);
        return;
    }
    char buffer[32];
    const std::string_view s = format_double(v, buffer);
    std::fwrite(s.data(), 1, s.size(), f);
}

void write_json_string(std::FILE* f, std::string_view s) {
    std::fputc('"', f);
    for (char c : s) {
        if (c == '"' || c == '\\')
            std::fputc('\\', f), std::fputc(c, f);
        else if (static_cast<unsigned char>(c) < 0x20)
            std::fprintf(f, "\\u%04x", static_cast<unsigned>(c));
        else
            std::fputc(c, f);
    }
    std::fputc('"', f);
}

void install_interrupt_handler() {
    std::signal(SIGINT, on_interrupt);
    std::signal(SIGTERM, on_interrupt);
}

bool interrupt_requested() { return interrupt_flag != 0; }

progress_bar::progress_bar(std::uint64_t total, std::uint64_t check_every)
    : total_(total),
      check_every_(check_every == 0 ? 1 : check_every),
      enabled_(::isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()) {}

bool progress_bar::due() {
    using namespace std::chrono;
    const auto now = steady_clock::now();
    // Short runs show nothing; a long one redraws at most ten times a second.
    if (now - start_ < seconds(1) || (shown_ && now - last_draw_ < milliseconds(100))) return false;
    last_draw_ = now;
    return true;
}

void progress_bar::draw(std::uint64_t i, double t, const std::string& detail) {
    using namespace std::chrono;
    shown_ = true;
    const double fraction = total_ ? double(i) / double(total_) : 1.0;
    constexpr int width = 40;
    const int filled = static_cast<int>(fraction * width);
    char bar[width + 1];
    for (int k = 0; k < width; ++k) bar[k] = k < filled ? '#' : '.';
    bar[width] = '\0';
    const double elapsed = duration<double>(last_draw_ - start_).count();
    const double remaining = fraction > 0.0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
    std::fprintf(stderr, "\r[%s] %5.1f%%  t = %-12.6g  %.0f s left %s", bar, 100.0 * fraction, t, remaining,
                 detail.c_str());
    std::fflush(stderr);
}

void progress_bar::finish() {
    if (!shown_) return;
    std::fputs("\r\033[K", stderr);
    std::fflush(stderr);
    shown_ = false;
}

}  // namespace eci::cli

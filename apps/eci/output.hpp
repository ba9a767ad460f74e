// What `eci run` writes besides numbers: files that appear only when complete, the CLI's error kinds, number
// formatting at full precision, a progress bar and the handling of Ctrl-C.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <string_view>

namespace eci::cli {

/// Input the CLI rejects: main prints "eci: error: <what>" and exits with status 2.
class bad_input : public std::runtime_error {
   public:
    using std::runtime_error::runtime_error;
};

/// A run that started but could not finish (a step that failed at every step size): exit status 1.
class run_failure : public std::runtime_error {
   public:
    using std::runtime_error::runtime_error;
};

/// The run was stopped by SIGINT or SIGTERM: exit status 130.
class interrupted : public std::runtime_error {
   public:
    using std::runtime_error::runtime_error;
};

/// A file written under a temporary name in its own directory and renamed over `path` by commit(), so a
/// reader never sees a partial file and a failed run leaves the old file (if any) untouched. "-" is stdout.
class output_file {
   public:
    /// No file: get() is null.
    output_file() = default;
    /// Creates the temporary now, so an unwritable path is reported before the run; throws bad_input.
    output_file(std::string path, std::string_view what);
    output_file(const output_file&) = delete;
    output_file& operator=(const output_file&) = delete;
    /// Removes the temporary unless commit() succeeded.
    ~output_file();

    /// The stream to write to, or null when there is no file.
    std::FILE* get() const { return file_; }
    /// Flushes, closes and renames the temporary over the path; throws bad_input on an I/O error.
    void commit();

   private:
    std::string path_, temp_, what_;
    std::FILE* file_ = nullptr;
    bool to_stdout_ = false;
};

/// v with 17 significant digits (what %.17g gives: enough to read back the same double).
std::string_view format_double(double v, char (&buffer)[32]);

/// Writes v as a JSON number (17 significant digits), or null if it is not finite.
void write_json_number(std::FILE* f, double v);

/// Writes s as a JSON string.
void write_json_string(std::FILE* f, std::string_view s);

/// Installs the SIGINT/SIGTERM handler that makes interrupt_requested() true.
void install_interrupt_handler();

/// Whether SIGINT or SIGTERM has arrived since install_interrupt_handler().
bool interrupt_requested();

/// A one-line progress bar on stderr, shown only when stderr is a terminal and the run has lasted over a
/// second. update() is cheap: it looks at the clock once every 4096 calls.
class progress_bar {
   public:
    /// A bar for a run of `total` steps; the clock is read every `check_every` updates (1 for slow steps).
    explicit progress_bar(std::uint64_t total, std::uint64_t check_every = 4096);
    ~progress_bar() { finish(); }
    progress_bar(const progress_bar&) = delete;
    progress_bar& operator=(const progress_bar&) = delete;

    /// Called at every step i (time t).
    void update(std::uint64_t i, double t) {
        if (enabled_ && (++calls_ % check_every_) == 0 && due()) draw(i, t, {});
    }
    /// The same, with detail() (called only when the bar is redrawn: it may be costly) appended to the line.
    template <class Detail>
    void update(std::uint64_t i, double t, Detail&& detail) {
        if (enabled_ && (++calls_ % check_every_) == 0 && due()) draw(i, t, detail());
    }
    /// Erases the bar, if it was drawn.
    void finish();

   private:
    bool due();
    void draw(std::uint64_t i, double t, const std::string& detail);

    std::uint64_t total_;
    std::uint64_t check_every_;
    std::uint64_t calls_ = 0;
    bool enabled_;
    bool shown_ = false;
    std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace eci::cli

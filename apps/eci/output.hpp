// What `eci run` writes besides numbers: files that appear only when complete (and all of a run's files
// together), the CLI's error kinds, number formatting at full precision, a progress bar and the signals.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <initializer_list>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include <eci/format.hpp>
#include <eci/progress.hpp>

namespace eci::cli {

/// Input the CLI rejects: main prints "eci: error: <what>" and exits with status 2.
class bad_input : public std::runtime_error {
   public:
    using std::runtime_error::runtime_error;
};

/// A run that started but could not finish (a step that failed at every step size): exit status 1.
class run_error : public std::runtime_error {
   public:
    using std::runtime_error::runtime_error;
};

/// The run was stopped by a signal (SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE): exit status 128 + signal.
class interrupted : public std::runtime_error {
   public:
    using std::runtime_error::runtime_error;
};

class staging_dir;

/// An output of one run. A regular file (new, or existing and writable) is written under a temporary name
/// beside it (beside a symlink's final target, so the link is kept) and renamed over it by commit_outputs(),
/// keeping the replaced file's mode; a reader never sees a partial file and a failed run leaves the old
/// file untouched. "-", /dev/stdout, /dev/fd/N and special files (devices, FIFOs, /proc) are written directly.
class output_file {
   public:
    /// No file: get() is null.
    output_file() = default;
    /// Opens the output now, so an unwritable path is reported before the run; throws bad_input.
    output_file(std::string path, std::string_view what);
    output_file(const output_file&) = delete;
    output_file& operator=(const output_file&) = delete;
    /// Removes the temporary unless it was committed.
    ~output_file();

    /// The stream to write to, or null when there is no file.
    std::FILE* get() const { return file_; }
    /// Flushes and closes the temporary (or flushes a direct stream); throws bad_input on an I/O error.
    void finish();
    /// Whether the output goes through a temporary file and a rename.
    bool replaces() const { return !temp_.empty(); }
    /// The temporary the rename commits (empty for direct output): for a file written by name (HDF5), which
    /// finish() then syncs to disk through the stream's descriptor (the same file) before the rename.
    const std::string& temporary() const { return temp_; }

   private:
    friend void commit_outputs(std::initializer_list<output_file*> outputs, staging_dir* staged, bool interrupted_run);
    void discard();

    std::string path_;    ///< as the user wrote it (messages)
    std::string target_;  ///< the file the rename replaces (symlinks resolved)
    std::string temp_;    ///< the temporary beside target_, empty for direct output
    std::string what_;
    std::FILE* file_ = nullptr;
    bool owns_stream_ = false;  ///< file_ is ours to close (not stdout)
    bool finished_ = false;
    int temp_slot_ = -1;  ///< the temporary's slot in the signal handler's cleanup list
};

/// Commits the outputs of one run together: finishes every file (a write error shows up here, before anything is
/// replaced), then moves the staged files in (`staged`, if any: the snapshots), then renames every temporary over
/// its target, the files that describe the run (CSV, JSON) last. If any step fails, what was already replaced gets
/// its old content back (a new file is removed) and run_error is thrown, naming the failure and ending in
/// "; no output was replaced", or, if something could not be taken back, "; committed: ...; not committed: ...".
/// If an interrupt has arrived, nothing is committed and `interrupted` is thrown, unless `interrupted_run`: the
/// outputs of a run stopped by an interrupt, complete up to where it stopped, kept (interrupt_keeps_outputs). On
/// success the interrupt signals stay blocked: the run is complete.
void commit_outputs(std::initializer_list<output_file*> outputs, staging_dir* staged = nullptr,
                    bool interrupted_run = false);

/// Whether a run stopped by the interrupt that arrived keeps what it wrote so far (its rows, snapshots, summary):
/// SIGINT, SIGTERM, SIGHUP and SIGQUIT ask the run to stop, and it keeps them; SIGPIPE is an output that failed
/// (its reader went away), and keeps nothing.
bool interrupt_keeps_outputs();

/// The interrupt's message, "interrupted by SIGINT <where>" ("interrupted <where>" if none arrived).
std::string interrupt_message(std::string_view where);

/// The extension of a file name, lowercase, without its dot ("" if there is none): what --plot and --output FILE.h5
/// are told apart by.
std::string extension_of(std::string_view path);

/// Whether `path` names a stream rather than a file: standard output ("-"), or an existing device, FIFO or socket
/// (by name, a symlink or /dev/fd/N).
bool names_a_stream(const std::string& path);

/// Refuses (bad_input "cannot write <what> into '<dir>': it is in /proc, a kernel interface, ...") a directory of
/// outputs, existing or to be created, in /proc, /sys or another kernel interface (mkdir's and mkdtemp's errors
/// there named no such file or directory).
void check_data_directory(const std::string& dir, std::string_view what);

/// A temporary directory beside `final_dir` whose contents replace `final_dir`'s files of the same names on
/// commit(); removed with its contents unless committed, and by the signal handler on a forced exit.
class staging_dir {
   public:
    /// Creates the temporary directory (final_dir itself appears on commit if missing); throws bad_input. `what`
    /// names the staged files in messages ("snapshots", "figures").
    explicit staging_dir(const std::string& final_dir, std::string what = "figures");
    staging_dir(const staging_dir&) = delete;
    staging_dir& operator=(const staging_dir&) = delete;
    ~staging_dir();

    /// The temporary directory to write into.
    const std::string& path() const { return path_; }
    /// Moves every file of the temporary directory into final_dir (replacing files of the same name, keeping
    /// their mode), restoring the replaced ones if a move fails; throws run_error or interrupted. (For a run with
    /// other outputs too: commit_outputs.)
    void commit();

   private:
    friend void commit_outputs(std::initializer_list<output_file*> outputs, staging_dir* staged, bool interrupted_run);
    // The commit in two phases, so that a later failure (another output's rename) can take the files back.
    /// Moves the files in, keeping the replaced ones aside; on a failure takes back what it moved (partly_moved_in_
    /// if it could not all) and throws run_error. Signals must be blocked.
    void move_in();
    /// After move_in: puts the replaced files back and removes the new ones. Returns false if any could not be.
    bool take_back();
    /// After move_in: drops the replaced files and the temporary directory.
    void finish_commit();

    std::string final_, path_, what_;
    int slot_ = -1;
    bool committed_ = false;
    bool moved_whole_ = false;  ///< final_ did not exist: the temporary directory was renamed to it
    bool partly_moved_in_ = false;  ///< move_in failed and could not take back all it had moved
    std::vector<std::pair<std::string, std::string>> replaced_;  ///< (target, the replaced file kept aside)
    std::vector<std::string> created_;                           ///< targets that did not exist
    std::vector<std::string> overwritten_;                       ///< targets replaced with no copy kept aside
};

// ---- The one path for the files eci writes by name (checkpoints, snapshots, spectra, pictures, FFTW wisdom) ----

/// Checks, before any work, that `path` can be replaced by a regular file: symlinks are followed (a dangling one
/// names the file it would create); a directory, FIFO, device or socket, a file in /proc or /sys, a read-only
/// file, a missing directory or one where no file can be created (tried with a temporary, removed at once) is
/// refused with bad_input ("cannot write <what> '<path>': ..."). Returns the file the rename will replace.
std::string check_output_path(const std::string& path, std::string_view what);

/// Writes `path` through a temporary beside its final target (so a symlink is kept and written through):
/// write(temp) fills the temporary by name and throws on any failure (checked writes and close); then the
/// temporary is synced to disk and renamed over the target, keeping the replaced file's mode. The temporary is
/// registered with the signal handler (removed on a forced exit) and removed on every failure; the target is
/// then untouched. Throws run_error (or what write throws).
void write_replacing(const std::string& path, std::string_view what,
                     const std::function<void(const std::string& temp)>& write);

/// Creates `file` (which must not exist, unless `exclusive` is false: write_replacing's temporary) and writes it
/// with fill(stream), checking every write, the flush, the sync to disk and the close; on a failure the file is
/// removed and run_error is thrown.
void write_new_file(const std::string& file, std::string_view what, const std::function<void(std::FILE*)>& fill,
                    bool exclusive = true);

/// Why a write to `file` failed, for a message: the system's text for `error` (an errno value) if it is not 0, else
/// what the file system says (statvfs of the file's directory: "No space left on device" when no block or inode is
/// left, or a read-only file system), else `otherwise`.
std::string write_failure_reason(const std::string& file, int error,
                                 std::string_view otherwise = "the write failed, no reason given");

/// Flushes a file written by name (by HDF5, gnuplot) to disk; throws run_error.
void sync_file(const std::string& file, std::string_view what);

/// The contents of a small regular file (symlinks followed), or nothing if there is no such file. Opened without
/// blocking (a FIFO never hangs); a directory, FIFO, device or a file over max_bytes is refused with bad_input.
std::optional<std::string> read_small_file(const std::string& path, std::string_view what, std::size_t max_bytes);

/// Why `path` cannot be read as a regular file ("no such file", "it is a FIFO, not a regular file", the system's
/// reason), or empty if it can be opened as one (symlinks followed).
std::string unreadable_reason(const std::string& path);

/// Refuses (bad_input "<a> and <b> name the same file '<path>'") two of the named outputs (option, path) that are
/// one file: symlinks followed, dangling ones too, and hard links. Empty paths, "-" and descriptors are skipped.
void check_distinct_files(const std::vector<std::pair<std::string, std::string>>& outputs);

/// Refuses (bad_input "<output> and <input> name the same file '<path>': the run would overwrite its own input") an
/// output (option, path) that is one of the run's input files, by the same test as check_distinct_files.
void check_outputs_spare_inputs(const std::vector<std::pair<std::string, std::string>>& outputs,
                                const std::vector<std::pair<std::string, std::string>>& inputs);

/// v with 17 significant digits (the CSV, the summary): eci::format_double, as the library formats it.
using eci::format_double;

/// Writes v as a JSON number (17 significant digits), or null if it is not finite.
void write_json_number(std::FILE* f, double v);

/// Writes s as a JSON string.
void write_json_string(std::FILE* f, std::string_view s);

/// Installs the handler of SIGINT, SIGTERM, SIGHUP, SIGQUIT and SIGPIPE (whatever disposition the parent left,
/// ignored ones included) and unblocks them: the first one sets the cancel flag (polled by the library's drivers
/// and the CLI's loops) and arms a watchdog; if the program has not stopped after 0.3 s more of its own CPU time
/// or 1 s of wall time, or a second signal arrives, the handler removes the temporaries, stops child processes
/// and exits with 128 + signal itself. The eci program calls it before any of its own code runs (main.cpp).
void install_interrupt_handler();

/// Whether an interrupt has arrived since install_interrupt_handler().
bool interrupt_requested();

/// The flag the library's drivers poll (run_options::cancel).
const std::atomic<bool>* cancel_flag();

/// The signal that interrupted the run (0 if none).
int interrupt_signal();

/// The exit status for an interrupt: 128 + the signal (130 for SIGINT).
int interrupt_exit_status();

/// Throws `interrupted` ("interrupted by SIGINT <where>") if an interrupt has arrived.
void throw_if_interrupted(std::string_view where = {});

/// Registers a child process (group) for the signal handler to kill on a forced exit; 0 unregisters.
void register_child(pid_t pid);

/// How long the run may need, after an interrupt, to reach its next poll and write its checkpoint: the watchdog
/// then allows that much of the process's CPU time (at least 0.3 s) and wall time (at least 1 s) before it exits
/// by itself. A run whose one step takes longer than the default (a large grid) sets it from its measured step
/// time, so that Ctrl-C finishes the step and writes the checkpoint; a second signal still exits at once.
void set_interrupt_grace(double cpu_seconds, double wall_seconds);

/// Runs `program args...` (PATH lookup, no shell) in its own process group, standard input /dev/null, its output
/// discarded if `quiet`. The wait polls the interrupt flag: on an interrupt the child's group is killed and -1
/// returned (the caller decides what the interrupt means; nothing is thrown). A program still running after
/// `time_limit` seconds of wall time (0: no limit) is killed with its group and program_timed_out returned.
/// Otherwise the exit status, 127 if the program could not be started, 128 if it died of a signal.
int run_program(const std::string& program, const std::vector<std::string>& args, bool quiet = true,
                double time_limit = 0.0);
inline constexpr int program_timed_out = -2;

/// How long the plotting program may take over one picture (or its --version), in seconds: $ECI_PLOT_TIMEOUT if it
/// is a positive number, else 600. A plotting program that hangs (a terminal waiting for a display, a script
/// that never ends) would otherwise hold a run at its first picture for ever.
double plotting_time_limit();

/// Why pictures are no longer drawn, if the plotting program ran past plotting_time_limit() once (then
/// plotting_available() is false for the rest of the run); empty otherwise.
std::string plotting_failure();

/// The plotting program every picture is drawn with (figures, snapshots, spectra): $ECI_GNUPLOT if set and not
/// empty, else `gnuplot` from PATH.
std::string plotting_program();

/// Whether the plotting program (plotting_program()) runs: pictures are drawn only then.
bool plotting_available();

/// Runs a gnuplot script (written beside `output` as a temporary) that draws the PNG `output`. False when the
/// plotting program is missing, cannot draw (no pngcairo) or was stopped by an interrupt (which the caller then
/// honours). A picture not written whole on a file system with no space left is a run_error with the reason.
bool draw_picture(const std::string& script, const std::string& output);
/// A number as gnuplot reads it back exactly (%.17g; std::to_string's %f printed 1e-13 as 0.000000), NaN (a gap in
/// a line) for one that is not finite.
std::string gnuplot_number(double v);
/// A gnuplot string in single quotes (a quote inside doubled).
std::string gnuplot_quoted(const std::string& s);
/// A field's picture, as a snapshot's and a spectral run's --plot draw it: writes the n x n values (row-major, y
/// rows) as doubles to the new file `data` and returns the gnuplot commands that draw them on [0, 2 pi)^2 as an
/// image, x and y labelled, in a diverging colour map symmetric about 0 (to the largest |value|; 1 for a zero field),
/// the colour bar labelled `symbol`. Throws run_error if the data cannot be written.
std::string field_image(const std::string& data, int n, const std::vector<double>& field, const std::string& symbol);

/// A directory the run has just created: removed when this goes out of scope, and by the signal handler on a forced
/// exit, if it is empty then (what the run wrote into it is removed first); keep() once the run has succeeded.
class created_directory {
   public:
    explicit created_directory(std::string path);
    ~created_directory();
    created_directory(const created_directory&) = delete;
    created_directory& operator=(const created_directory&) = delete;
    void keep();

   private:
    std::string path_;
    int slot_;
};

/// A file removed when this goes out of scope and, if the process is forced to exit by a signal, by the handler
/// (a temporary another program reads, such as gnuplot's data).
class scoped_temporary {
   public:
    explicit scoped_temporary(std::string path);
    ~scoped_temporary();
    scoped_temporary(const scoped_temporary&) = delete;
    scoped_temporary& operator=(const scoped_temporary&) = delete;
    const std::string& path() const { return path_; }

   private:
    std::string path_;
    int slot_;
};

/// A line on stderr while something slow runs that draws no progress bar (FFTW's planning): shown only when stderr
/// is a terminal and the work has lasted over `after`, erased when the object ends.
class delayed_status {
   public:
    explicit delayed_status(std::string text, std::chrono::milliseconds after = std::chrono::seconds(1));
    ~delayed_status();
    delayed_status(const delayed_status&) = delete;
    delayed_status& operator=(const delayed_status&) = delete;

   private:
    std::mutex mutex_;
    std::condition_variable done_cv_;
    bool done_ = false, shown_ = false;
    std::thread waiter_;
};

/// A one-line progress bar on stderr, shown only when stderr is a terminal and the run has lasted over a
/// second. update() is cheap: it looks at the clock once every 4096 calls.
class progress_bar {
   public:
    /// A bar for a run of `total` steps; the clock is read every `check_every` updates (1 for slow steps). A run
    /// of unknown step count (adaptive: total 0) shows the fraction of its span [0, t_end] instead.
    explicit progress_bar(std::uint64_t total, std::uint64_t check_every = 4096, double t_end = 0.0);
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
    bool due() { return pace_.due(); }
    void draw(std::uint64_t i, double t, const std::string& detail);

    std::uint64_t total_;
    std::uint64_t check_every_;
    double t_end_;
    std::uint64_t calls_ = 0;
    bool enabled_;
    bool shown_ = false;
    progress_pace pace_;  // (eci.solve's progress line keeps the same pace and text: eci/progress.hpp)
};

}  // namespace eci::cli

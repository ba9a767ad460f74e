// Output plumbing of the CLI: files committed together by rename (or written directly when they are special),
// staged directories, full-precision numbers, JSON scalars, the progress bar and the signal handling that
// cleans up after itself. No numerics here.
#include "output.hpp"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cmath>
#include <csignal>
#include <ctime>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <initializer_list>
#include <system_error>
#include <vector>

#include <dirent.h>
#include <fcntl.h>
#include <linux/magic.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/syscall.h>
#include <sys/time.h>
#include <sys/vfs.h>
#include <sys/wait.h>
#include <unistd.h>

namespace eci::cli {

namespace {

// ---- What the signal handler may touch: lock-free atomics and fixed buffers only. ----

std::atomic<bool> cancel{false};
volatile std::sig_atomic_t signal_number = 0;
// When the first interrupt arrived (CLOCK_MONOTONIC, nanoseconds): a copy of the same signal within 0.2 s is the
// same request (timeout(1) and a terminal's Ctrl-C signal both the process and its group), not a second one.
std::atomic<long long> first_signal_ns{0};

long long monotonic_ns() {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);  // async-signal-safe
    return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}
std::atomic<pid_t> child_pid{0};
// Whether a delayed_status line is on the terminal: a forced exit erases it before its message.
std::atomic<bool> status_line_on{false};
// The watchdog's allowance after an interrupt (set_interrupt_grace), in microseconds.
std::atomic<long long> grace_cpu_us{300000}, grace_wall_us{1000000};

/// A path the handler removes on a forced exit: a file (kind 1), a flat directory (kind 2), or a directory the run
/// created, if it is then empty (kind 3: after the others, which may have emptied it).
struct cleanup_slot {
    std::atomic<int> kind{0};
    char path[PATH_MAX];
};
constexpr int cleanup_slots = 16;
cleanup_slot cleanup[cleanup_slots];
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free &&
              std::atomic<pid_t>::is_always_lock_free);

constexpr int handled_signals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE};

const char* signal_name(int s) {
    switch (s) {
        case SIGINT: return "SIGINT";
        case SIGTERM: return "SIGTERM";
        case SIGHUP: return "SIGHUP";
        case SIGQUIT: return "SIGQUIT";
        case SIGPIPE: return "SIGPIPE";
        default: return "a signal";
    }
}

int register_cleanup(const std::string& path, int kind) {
    if (path.size() >= PATH_MAX) return -1;
    for (int i = 0; i < cleanup_slots; ++i) {
        int expected = 0;
        // -1 reserves the slot while the path is copied; the handler ignores it until the kind is set.
        if (cleanup[i].kind.compare_exchange_strong(expected, -1)) {
            std::memcpy(cleanup[i].path, path.c_str(), path.size() + 1);
            cleanup[i].kind.store(kind);
            return i;
        }
    }
    return -1;  // more temporaries than slots: still removed by their owners, only not on a forced exit
}

void unregister_cleanup(int slot) {
    if (slot >= 0) cleanup[slot].kind.store(0);
}

// Removes a directory and the files in it with system calls only (getdents64, unlinkat, rmdir).
void remove_flat_dir_signal_safe(const char* dir) {
    const int fd = ::open(dir, O_RDONLY | O_DIRECTORY);
    if (fd >= 0) {
        alignas(8) char buffer[4096];
        for (;;) {
            const long n = ::syscall(SYS_getdents64, fd, buffer, sizeof buffer);
            if (n <= 0) break;
            for (long at = 0; at < n;) {
                // struct linux_dirent64: u64 ino, s64 off, u16 reclen, u8 type, char name[]
                unsigned short reclen;
                std::memcpy(&reclen, buffer + at + 16, sizeof reclen);
                const char* name = buffer + at + 19;
                if (!(name[0] == '.' && (name[1] == '\0' || (name[1] == '.' && name[2] == '\0'))))
                    ::unlinkat(fd, name, 0);
                at += reclen;
            }
        }
        ::close(fd);
    }
    ::rmdir(dir);
}

void write_stderr(const char* s) {
    std::size_t n = std::strlen(s);
    while (n > 0) {
        const ssize_t w = ::write(STDERR_FILENO, s, n);
        if (w <= 0) return;
        s += w, n -= static_cast<std::size_t>(w);
    }
}

[[noreturn]] void forced_exit() {
    const pid_t child = child_pid.load();
    if (child > 0) ::kill(-child, SIGKILL);  // the child runs in its own process group
    for (cleanup_slot& c : cleanup) {
        const int kind = c.kind.load();
        if (kind == 1) ::unlink(c.path);
        if (kind == 2) remove_flat_dir_signal_safe(c.path);
    }
    for (cleanup_slot& c : cleanup)
        if (c.kind.load() == 3) ::rmdir(c.path);  // fails, as it should, if anything is left in it
    const int s = signal_number ? signal_number : SIGINT;
    if (status_line_on.load()) write_stderr("\r\033[K");
    write_stderr("eci: error: interrupted by ");
    write_stderr(signal_name(s));
    write_stderr("\n");
    ::_exit(128 + s);
}

extern "C" void on_interrupt(int s) {
    if (!cancel.load()) {
        signal_number = s;
        first_signal_ns.store(monotonic_ns());
        cancel.store(true);
        // The run stops at its next poll; if it has not, the watchdog stops it here, cleaning up the same way:
        // after 0.3 s of its own CPU time (a long right-hand side; CPU time, so that a process merely waiting
        // for a busy machine's core still stops gracefully) or 1 s of wall time (a blocked write), or the longer
        // allowance a run with long steps has set (set_interrupt_grace).
        const long long cpu = grace_cpu_us.load(), wall = grace_wall_us.load();
        itimerval watchdog{};
        watchdog.it_value.tv_sec = static_cast<time_t>(cpu / 1000000);
        watchdog.it_value.tv_usec = static_cast<suseconds_t>(cpu % 1000000);
        ::setitimer(ITIMER_VIRTUAL, &watchdog, nullptr);
        watchdog.it_value.tv_sec = static_cast<time_t>(wall / 1000000);
        watchdog.it_value.tv_usec = static_cast<suseconds_t>(wall % 1000000);
        ::setitimer(ITIMER_REAL, &watchdog, nullptr);
        return;
    }
    if (s == signal_number && monotonic_ns() - first_signal_ns.load() < 200000000LL) return;  // the same request
    if (s != SIGPIPE) forced_exit();  // asked twice; repeated SIGPIPEs are just more failed writes
}

extern "C" void on_watchdog(int) {
    if (cancel.load()) forced_exit();
}

sigset_t interrupt_set() {
    sigset_t set;
    sigemptyset(&set);
    for (int s : handled_signals) sigaddset(&set, s);
    sigaddset(&set, SIGALRM);
    sigaddset(&set, SIGVTALRM);
    return set;
}

// ---- Files ----

std::string errno_text(int e = errno) { return std::strerror(e); }

// Built with append, not operator+ chains, which trip a false -Wrestrict in GCC 12's libstdc++.
std::string message(std::initializer_list<std::string_view> parts) {
    std::string s;
    for (std::string_view p : parts) s.append(p);
    return s;
}

std::string dir_of(const std::string& path) {
    const std::size_t slash = path.find_last_of('/');
    if (slash == std::string::npos) return ".";
    if (slash == 0) return "/";
    return path.substr(0, slash);
}

std::string base_of(const std::string& path) {
    const std::size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? path : path.substr(slash + 1);
}

// A temporary name beside `target`: ".<name>.eci-tmp-XXXXXX", the name cut so the whole stays far below
// NAME_MAX (255 bytes) however long the target's name is.
std::string temp_template(const std::string& target, std::string_view tag) {
    std::string base = base_of(target);
    constexpr std::size_t keep = 96;
    if (base.size() > keep) base.resize(keep);
    return message({dir_of(target), "/.", base, tag, "XXXXXX"});
}

// The file a path finally names: symlinks followed (a dangling one names the file it would create). Returns
// false with errno set for a loop or an unreadable link.
bool resolve_links(std::string path, std::string& out) {
    for (int depth = 0; depth < 40; ++depth) {
        struct stat st {};
        if (::lstat(path.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) {
            out = path;
            return true;
        }
        std::vector<char> buffer(static_cast<std::size_t>(st.st_size > 0 ? st.st_size : PATH_MAX) + 1);
        const ssize_t n = ::readlink(path.c_str(), buffer.data(), buffer.size() - 1);
        if (n < 0) return false;
        std::string link(buffer.data(), static_cast<std::size_t>(n));
        path = link.empty() || link[0] == '/' ? link : message({dir_of(path), "/", link});
    }
    errno = ELOOP;
    return false;
}

// The kernel's pseudo file systems, whose files are interfaces, not storage: their name, or null.
const char* pseudo_file_system(const std::string& path) {
    struct statfs fs {};
    if (::statfs(path.c_str(), &fs) != 0) return nullptr;
    switch (static_cast<unsigned long>(fs.f_type)) {
        case PROC_SUPER_MAGIC: return "/proc";
        case SYSFS_MAGIC: return "/sys";
        case CGROUP_SUPER_MAGIC:
        case CGROUP2_SUPER_MAGIC: return "a cgroup file system";
        case DEBUGFS_MAGIC: return "debugfs";
        case SECURITYFS_MAGIC: return "securityfs";
        default: return nullptr;
    }
}

// "/dev/stdout", "/dev/fd/3", "/proc/self/fd/3": the descriptor they name, or -1.
int named_descriptor(const std::string& path) {
    if (path == "/dev/stdin") return 0;
    if (path == "/dev/stdout") return 1;
    if (path == "/dev/stderr") return 2;
    for (std::string_view prefix : {"/dev/fd/", "/proc/self/fd/"}) {
        if (path.compare(0, prefix.size(), prefix) != 0) continue;
        const char* digits = path.c_str() + prefix.size();
        int fd = -1;
        const auto r = std::from_chars(digits, path.c_str() + path.size(), fd);
        if (r.ec == std::errc() && r.ptr == path.c_str() + path.size() && fd >= 0) return fd;
    }
    return -1;
}

}  // namespace

// ---- output_file ----

output_file::output_file(std::string path, std::string_view what) : path_(std::move(path)), what_(what) {
    const auto fail = [&](int e) {
        return bad_input(message({"cannot write ", what_, " '", path_, "': ", errno_text(e)}));
    };
    if (path_.empty()) throw bad_input(message({what_, ": the file name is empty"}));
    if (path_ == "-") {
        file_ = stdout;
        return;
    }
    // A descriptor by name: write to it directly (a rename would replace /dev/stdout, or the file behind it).
    if (const int fd = named_descriptor(path_); fd >= 0) {
        if (fd == STDOUT_FILENO) {
            file_ = stdout;
            return;
        }
        const int copy = ::fcntl(fd, F_DUPFD_CLOEXEC, 3);
        if (copy < 0) throw fail(errno);
        file_ = ::fdopen(copy, "w");
        if (!file_) {
            const int e = errno;
            ::close(copy);
            throw fail(e);
        }
        owns_stream_ = true;
        return;
    }
    if (path_.back() == '/') throw bad_input(message({what_, " '", path_, "' names a directory, not a file"}));
    if (!resolve_links(path_, target_)) throw fail(errno);
    // A name longer than the directory allows would only fail at the final rename, after the whole run.
    {
        const long name_max = ::pathconf(dir_of(target_).c_str(), _PC_NAME_MAX);
        if (base_of(target_).size() > static_cast<std::size_t>(name_max > 0 ? name_max : NAME_MAX))
            throw bad_input(message({"cannot write ", what_, " '", path_, "': the file name is too long (",
                                     std::to_string(base_of(target_).size()), " bytes, at most ",
                                     std::to_string(name_max > 0 ? name_max : NAME_MAX), ")"}));
    }

    struct stat st {};
    const bool exists = ::stat(target_.c_str(), &st) == 0;
    if (exists && S_ISDIR(st.st_mode)) throw bad_input(message({what_, " '", path_, "' is a directory"}));
    // /proc/self/status is a "regular file" of size 0 that no data belongs in; a new file cannot be made there.
    if (const char* pseudo = pseudo_file_system(exists ? target_ : dir_of(target_)))
        throw bad_input(message({"cannot write ", what_, " '", path_, "': it is in ", pseudo,
                                 ", a kernel interface, not a place for data files"}));
    if (exists && !S_ISREG(st.st_mode)) {
        // A device or FIFO: written directly, as a shell redirection would. O_NONBLOCK so that a
        // FIFO without a reader is an error (ENXIO) instead of a hang; cleared once it is open.
        const int fd = ::open(target_.c_str(), O_WRONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
        if (fd < 0) {
            const int e = errno;
            if (e == ENXIO && S_ISFIFO(st.st_mode))
                throw bad_input(message({"cannot write ", what_, " '", path_, "': the FIFO has no reader"}));
            throw fail(e);
        }
        ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
        file_ = ::fdopen(fd, "w");
        if (!file_) {
            const int e = errno;
            ::close(fd);
            throw fail(e);
        }
        owns_stream_ = true;
        return;
    }
    if (exists) {
        // root may write anything; a file nobody may write (0444) is still not replaced.
        if ((st.st_mode & 0222) == 0)
            throw bad_input(message({"cannot write ", what_, " '", path_, "': the file is read-only"}));
        if (::access(target_.c_str(), W_OK) != 0) throw fail(errno);
    }
    // The temporary goes beside the final target, so the rename neither crosses file systems nor replaces a
    // symlink.
    std::string temp = temp_template(target_, ".eci-tmp-");
    const int fd = ::mkstemp(temp.data());
    if (fd < 0) {
        const int e = errno;
        if (e == ENOENT)
            throw bad_input(message({"cannot write ", what_, " '", path_, "': directory '", dir_of(target_),
                                     "' does not exist"}));
        throw bad_input(message({"cannot write ", what_, " '", path_, "': cannot create a file in '",
                                 dir_of(target_), "': ", errno_text(e)}));
    }
    temp_ = temp;
    temp_slot_ = register_cleanup(temp_, 1);
    if (exists) {
        // The replacement keeps the replaced file's permissions (and, as root, its owner).
        ::fchmod(fd, st.st_mode & 07777);
        if (::geteuid() == 0 && ::fchown(fd, st.st_uid, st.st_gid) != 0) {
            // not fatal: the file is still written, with root's ownership
        }
    } else {
        // mkstemp makes the file private (0600); give it the permissions a plain fopen would.
        const mode_t mask = ::umask(0);
        ::umask(mask);
        ::fchmod(fd, 0666 & ~mask);
    }
    file_ = ::fdopen(fd, "w");
    if (!file_) {
        const int e = errno;
        ::close(fd);
        discard();
        throw fail(e);
    }
    owns_stream_ = true;
    static constexpr std::size_t buffer_size = 1 << 16;
    std::setvbuf(file_, nullptr, _IOFBF, buffer_size);
}

void output_file::discard() {
    if (!temp_.empty()) {
        ::unlink(temp_.c_str());
        unregister_cleanup(temp_slot_);
        temp_slot_ = -1;
        temp_.clear();
    }
}

output_file::~output_file() {
    if (file_ && owns_stream_ && !finished_) std::fclose(file_);
    discard();
}

void output_file::finish() {
    if (!file_ || finished_) return;
    finished_ = true;
    if (!owns_stream_) {
        if (std::fflush(file_) != 0 || std::ferror(file_))
            throw run_error(message({"cannot write ", what_, " to standard output: ", errno_text()}));
        return;
    }
    // An earlier write's failure (the stream's error flag) left no errno worth trusting by now: e stays 0 unless
    // the flush, sync or close below fails and says why.
    const bool write_failed = std::ferror(file_) != 0;
    int e = 0;
    // fflush first: a full disk shows up here, and fsync makes sure the data is on disk before the rename.
    const bool flush_failed = std::fflush(file_) != 0;
    if (flush_failed) e = errno;
    const bool sync_failed = !temp_.empty() && ::fsync(::fileno(file_)) != 0 && errno != EINVAL;
    if (sync_failed && e == 0) e = errno;
    const bool close_failed = std::fclose(file_) != 0;
    if (close_failed && e == 0) e = errno;
    if (write_failed || flush_failed || sync_failed || close_failed) {
        const std::string reason = write_failure_reason(temp_.empty() ? target_ : temp_, e);
        discard();
        throw run_error(message({"cannot write ", what_, " '", path_, "': ", reason}));
    }
}

namespace {

// The end of a commit's error message: what the failed commit left. `committed` names the outputs that now hold
// this run's data (their old content could not be restored), `not_committed` those that kept their old content.
std::string commit_state(const std::vector<std::string>& committed, const std::vector<std::string>& not_committed) {
    if (committed.empty()) return "; no output was replaced";
    std::string s = "; committed: ";
    for (std::size_t i = 0; i < committed.size(); ++i) s.append(i ? ", " : "").append(committed[i]);
    s.append("; not committed: ");
    if (not_committed.empty()) s.append("none");
    for (std::size_t i = 0; i < not_committed.size(); ++i) s.append(i ? ", " : "").append(not_committed[i]);
    return s;
}

}  // namespace

void commit_outputs(std::initializer_list<output_file*> outputs, staging_dir* staged, bool interrupted_run) {
    const auto name = [](const output_file* o) { return message({o->what_, " '", o->path_, "'"}); };
    if (!interrupted_run) throw_if_interrupted("before its output was committed");
    for (output_file* o : outputs) {
        if (!o) continue;
        try {
            o->finish();
        } catch (const run_error& e) {
            throw run_error(message({e.what(), commit_state({}, {})}));
        }
    }
    // No signal between the first move and the last: the outputs appear together or not at all.
    const sigset_t block = interrupt_set();
    sigset_t previous;
    ::pthread_sigmask(SIG_BLOCK, &block, &previous);
    try {
        if (!interrupted_run) throw_if_interrupted("before its output was committed");
        // The staged files (snapshots) first, the files that describe the run last: a CSV or JSON is never
        // committed for a run whose other files are not.
        const auto staged_name = [&] { return message({"the ", staged->what_, " in '", staged->final_, "'"}); };
        if (staged) {
            try {
                staged->move_in();
            } catch (const run_error& e) {
                std::vector<std::string> files;
                for (output_file* o : outputs)
                    if (o && o->replaces()) files.push_back(name(o));
                throw run_error(message({e.what(), staged->partly_moved_in_
                                                       ? commit_state({"some of " + staged_name()}, files)
                                                       : commit_state({}, {})}));
            }
        }
        struct replaced {
            output_file* o;
            std::string backup;  // a hard link to the old file, empty if there was none (or none could be made)
            bool existed;
        };
        std::vector<replaced> done;
        for (output_file* o : outputs) {
            if (!o || !o->replaces()) continue;
            replaced r{o, {}, false};
            struct stat st {};
            r.existed = ::lstat(o->target_.c_str(), &st) == 0;
            if (r.existed) {
                std::string backup = temp_template(o->target_, ".eci-old-");
                const int fd = ::mkstemp(backup.data());
                if (fd >= 0) {
                    ::close(fd);
                    ::unlink(backup.c_str());
                    if (::link(o->target_.c_str(), backup.c_str()) == 0) r.backup = backup;
                }
            }
            if (::rename(o->temp_.c_str(), o->target_.c_str()) != 0) {
                const int e = errno;
                if (!r.backup.empty()) ::unlink(r.backup.c_str());
                // Take back what this commit replaced, and say what could not be.
                std::vector<std::string> committed, not_committed;
                for (auto it = done.rbegin(); it != done.rend(); ++it) {
                    const bool restored = !it->backup.empty()
                                              ? ::rename(it->backup.c_str(), it->o->target_.c_str()) == 0
                                              : !it->existed && ::unlink(it->o->target_.c_str()) == 0;
                    (restored ? not_committed : committed).push_back(name(it->o));
                    if (!restored && !it->backup.empty()) ::unlink(it->backup.c_str());
                }
                for (output_file* other : outputs)
                    if (other && other->replaces()) not_committed.push_back(name(other));
                if (staged) (staged->take_back() ? not_committed : committed).push_back(staged_name());
                throw run_error(message({"cannot write ", name(o), ": ", errno_text(e),
                                         commit_state(committed, not_committed)}));
            }
            unregister_cleanup(o->temp_slot_);
            o->temp_slot_ = -1;
            o->temp_.clear();
            done.push_back(std::move(r));
        }
        for (const replaced& d : done)
            if (!d.backup.empty()) ::unlink(d.backup.c_str());
        if (staged) staged->finish_commit();
    } catch (...) {
        ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
        throw;
    }
    // Committed: the run is complete, so later signals (pending ones included) no longer interrupt it.
}

// ---- files written by name: one checked path ----

namespace {

const char* kind_of(mode_t m) {
    if (S_ISFIFO(m)) return "a FIFO";
    if (S_ISCHR(m)) return "a character device";
    if (S_ISBLK(m)) return "a block device";
    if (S_ISSOCK(m)) return "a socket";
    if (S_ISDIR(m)) return "a directory";
    return "not a regular file";
}

// The checks of check_output_path; `st` gets the target's status (st_mode 0 if it does not exist). With `probe`,
// a temporary is created beside the target and removed, so an unwritable directory is found now.
std::string inspect_output(const std::string& path, std::string_view what, struct stat& st, bool probe) {
    const auto refuse = [&](std::string_view why) {
        return bad_input(message({"cannot write ", what, " '", path, "': ", why}));
    };
    if (path.empty()) throw bad_input(message({what, ": the file name is empty"}));
    if (path == "-" || named_descriptor(path) >= 0) throw refuse("it must name a file, not a descriptor");
    if (path.back() == '/') throw refuse("it names a directory, not a file");
    std::string target;
    if (!resolve_links(path, target)) throw refuse(errno_text());
    const long name_max = ::pathconf(dir_of(target).c_str(), _PC_NAME_MAX);
    const std::size_t limit = static_cast<std::size_t>(name_max > 0 ? name_max : NAME_MAX);
    if (base_of(target).size() > limit) throw refuse("the file name is too long");
    st = {};
    const bool exists = ::stat(target.c_str(), &st) == 0;
    if (!exists) st.st_mode = 0;
    if (const char* pseudo = pseudo_file_system(exists ? target : dir_of(target)))
        throw refuse(message({"it is in ", pseudo, ", a kernel interface, not a place for data files"}));
    if (exists && !S_ISREG(st.st_mode))
        throw refuse(message({"it is ", kind_of(st.st_mode), "; eci writes its ", what, " only to regular files"}));
    if (exists && (st.st_mode & 0222) == 0) throw refuse("the file is read-only");
    if (exists && ::access(target.c_str(), W_OK) != 0) throw refuse(errno_text());
    if (probe) {
        std::string temp = temp_template(target, ".eci-tmp-");
        const int fd = ::mkstemp(temp.data());
        if (fd < 0) {
            const int e = errno;
            if (e == ENOENT) throw refuse(message({"directory '", dir_of(target), "' does not exist"}));
            throw refuse(message({"cannot create a file in '", dir_of(target), "': ", errno_text(e)}));
        }
        ::close(fd);
        ::unlink(temp.c_str());
    }
    return target;
}

}  // namespace

std::string check_output_path(const std::string& path, std::string_view what) {
    struct stat st {};
    return inspect_output(path, what, st, true);
}

std::string write_failure_reason(const std::string& file, int error, std::string_view otherwise) {
    if (error != 0) return errno_text(error);
    struct statvfs fs {};
    if (::statvfs(dir_of(file).c_str(), &fs) == 0) {
        if (fs.f_flag & ST_RDONLY) return errno_text(EROFS);
        // (root may use the reserved blocks: f_bfree, not f_bavail, is what is left for it)
        const bool no_blocks = (::geteuid() == 0 ? fs.f_bfree : fs.f_bavail) == 0;
        const bool no_inodes = fs.f_files > 0 && (::geteuid() == 0 ? fs.f_ffree : fs.f_favail) == 0;
        if (no_blocks || no_inodes) return errno_text(ENOSPC);
    }
    return std::string(otherwise);
}

void sync_file(const std::string& file, std::string_view what) {
    const int fd = ::open(file.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0 || (::fsync(fd) != 0 && errno != EINVAL)) {
        const int e = errno;
        if (fd >= 0) ::close(fd);
        throw run_error(message({"cannot write ", what, " '", file, "': ", write_failure_reason(file, e)}));
    }
    ::close(fd);
}

void write_replacing(const std::string& path, std::string_view what,
                     const std::function<void(const std::string& temp)>& write) {
    struct stat st {};
    std::string target;
    try {
        target = inspect_output(path, what, st, false);
    } catch (const bad_input& e) {
        throw run_error(e.what());  // checked before the run; changed since
    }
    std::string temp = temp_template(target, ".eci-tmp-");
    const int fd = ::mkstemp(temp.data());
    if (fd < 0) {
        const int e = errno;
        throw run_error(message({"cannot write ", what, " '", path, "': cannot create a file in '", dir_of(target),
                                 "': ", errno_text(e)}));
    }
    // The replacement keeps the replaced file's permissions; a new file gets what a plain fopen would give.
    if (st.st_mode != 0) {
        ::fchmod(fd, st.st_mode & 07777);
    } else {
        const mode_t mask = ::umask(0);
        ::umask(mask);
        ::fchmod(fd, 0666 & ~mask);
    }
    ::close(fd);
    struct cleanup_guard {
        std::string temp;
        int slot;
        ~cleanup_guard() {
            if (!temp.empty()) ::unlink(temp.c_str());
            unregister_cleanup(slot);
        }
    } guard{temp, register_cleanup(temp, 1)};
    try {
        write(temp);
        sync_file(temp, what);
    } catch (const run_error& e) {
        // named as the user wrote it, not by the temporary's name
        std::string m = e.what();
        for (std::size_t at; (at = m.find(temp)) != std::string::npos;) m.replace(at, temp.size(), path);
        throw run_error(m);
    }
    if (::rename(temp.c_str(), target.c_str()) != 0) {
        const int e = errno;
        throw run_error(message({"cannot write ", what, " '", path, "': ", errno_text(e)}));
    }
    guard.temp.clear();
}

void write_new_file(const std::string& file, std::string_view what, const std::function<void(std::FILE*)>& fill,
                    bool exclusive) {
    const int fd = ::open(file.c_str(), O_WRONLY | O_CLOEXEC | (exclusive ? O_CREAT | O_EXCL : O_TRUNC | O_NOFOLLOW), 0666);
    std::FILE* f = fd >= 0 ? ::fdopen(fd, "w") : nullptr;
    if (!f) {
        const int e = errno;
        if (fd >= 0) {
            ::close(fd);
            ::unlink(file.c_str());
        }
        throw run_error(message({"cannot write ", what, " '", file, "': ", errno_text(e)}));
    }
    int e = 0;
    try {
        fill(f);
    } catch (...) {
        std::fclose(f);
        ::unlink(file.c_str());
        throw;
    }
    // As in output_file::finish: the error flag of an earlier write keeps no trustworthy errno.
    const bool write_failed = std::ferror(f) != 0;
    const bool flush_failed = std::fflush(f) != 0;
    if (flush_failed) e = errno;
    const bool sync_failed = ::fsync(::fileno(f)) != 0 && errno != EINVAL;
    if (sync_failed && e == 0) e = errno;
    const bool close_failed = std::fclose(f) != 0;
    if (close_failed && e == 0) e = errno;
    if (write_failed || flush_failed || sync_failed || close_failed) {
        const std::string reason = write_failure_reason(file, e);
        ::unlink(file.c_str());
        throw run_error(message({"cannot write ", what, " '", file, "': ", reason}));
    }
}

std::string unreadable_reason(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return errno == ENOENT ? "no such file" : errno_text();
    if (!S_ISREG(st.st_mode)) return message({"it is ", kind_of(st.st_mode), ", not a regular file"});
    if (::access(path.c_str(), R_OK) != 0) return errno_text();
    return {};
}

std::optional<std::string> read_small_file(const std::string& path, std::string_view what, std::size_t max_bytes) {
    const auto refuse = [&](std::string_view why) {
        return bad_input(message({"cannot read ", what, " '", path, "': ", why}));
    };
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) {
        if (errno == ENOENT) return std::nullopt;
        throw refuse(errno_text());
    }
    if (!S_ISREG(st.st_mode)) throw refuse(message({"it is ", kind_of(st.st_mode), ", not a regular file"}));
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) throw refuse(errno_text());
    struct closer {
        int fd;
        ~closer() { ::close(fd); }
    } close_it{fd};
    if (::fstat(fd, &st) != 0) throw refuse(errno_text());
    if (!S_ISREG(st.st_mode)) throw refuse(message({"it is ", kind_of(st.st_mode), ", not a regular file"}));
    if (static_cast<std::size_t>(st.st_size) > max_bytes)
        throw refuse(message({"it is larger than ", std::to_string(max_bytes), " bytes"}));
    std::string text;
    char buffer[65536];
    for (;;) {
        const ssize_t n = ::read(fd, buffer, sizeof buffer);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw refuse(errno_text());
        if (n == 0) break;
        text.append(buffer, static_cast<std::size_t>(n));
        if (text.size() > max_bytes) throw refuse(message({"it is larger than ", std::to_string(max_bytes), " bytes"}));
    }
    return text;
}

namespace {

/// What makes two names one file: the absolute path with symlinks resolved (dangling ones too) and normalised, and,
/// for an existing file, its device and inode (hard links, bind mounts).
struct file_key {
    const std::string* name;
    const std::string* path;
    std::string canonical;
    bool exists;
    dev_t dev;
    ino_t ino;
    bool same(const file_key& o) const {
        return canonical == o.canonical || (exists && o.exists && dev == o.dev && ino == o.ino);
    }
};

/// The keys of the named files; empty paths, "-" and descriptors have none (they name no file of their own).
std::vector<file_key> file_keys(const std::vector<std::pair<std::string, std::string>>& files) {
    std::vector<file_key> keys;
    for (const auto& [name, path] : files) {
        if (path.empty() || path == "-" || named_descriptor(path) >= 0) continue;
        std::string target;
        if (!resolve_links(path, target)) target = path;
        std::error_code ec;
        // absolute first: weakly_canonical leaves a relative path with no existing prefix ("out") relative.
        std::filesystem::path c = std::filesystem::weakly_canonical(std::filesystem::absolute(target, ec), ec);
        struct stat st {};
        const bool exists = ::stat(target.c_str(), &st) == 0;
        keys.push_back({&name, &path, c.lexically_normal().string(), exists, st.st_dev, st.st_ino});
    }
    return keys;
}

}  // namespace

void check_distinct_files(const std::vector<std::pair<std::string, std::string>>& outputs) {
    // Two outputs through one descriptor ("-" is standard output, as /dev/stdout and /dev/fd/1 are) would
    // interleave there: "--output /dev/stdout --summary-json -" wrote the CSV and the JSON into one stream.
    const auto fd = [](const std::string& p) { return p == "-" ? 1 : p.empty() ? -1 : named_descriptor(p); };
    for (std::size_t i = 0; i < outputs.size(); ++i)
        for (std::size_t j = i + 1; j < outputs.size(); ++j) {
            const int a = fd(outputs[i].second);
            if (a >= 0 && a == fd(outputs[j].second))
                throw bad_input(a == 1 ? message({outputs[i].first, " and ", outputs[j].first,
                                                  " cannot both be standard output"})
                                       : message({outputs[i].first, " and ", outputs[j].first,
                                                  " cannot both write to file descriptor ", std::to_string(a)}));
        }
    const std::vector<file_key> keys = file_keys(outputs);
    for (std::size_t i = 0; i < keys.size(); ++i)
        for (std::size_t j = i + 1; j < keys.size(); ++j)
            if (keys[i].same(keys[j]))
                throw bad_input(message({*keys[i].name, " and ", *keys[j].name, " name the same file '",
                                         *keys[i].path, "'"}));
}

void check_outputs_spare_inputs(const std::vector<std::pair<std::string, std::string>>& outputs,
                                const std::vector<std::pair<std::string, std::string>>& inputs) {
    const std::vector<file_key> out = file_keys(outputs), in = file_keys(inputs);
    for (const file_key& o : out)
        for (const file_key& i : in)
            if (o.same(i))
                throw bad_input(message({*o.name, " and ", *i.name, " name the same file '", *o.path,
                                         "': the run would overwrite its own input"}));
}

std::string extension_of(std::string_view path) {
    const std::size_t dot = path.rfind('.');
    if (dot == std::string_view::npos || path.find('/', dot) != std::string_view::npos) return {};
    std::string ext(path.substr(dot + 1));
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

bool names_a_stream(const std::string& path) {
    struct stat st {};
    return path == "-" || (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode));
}

void check_data_directory(const std::string& dir, std::string_view what) {
    struct stat st {};
    const std::string where = ::stat(dir.c_str(), &st) == 0 ? dir : dir_of(dir);
    if (const char* pseudo = pseudo_file_system(where))
        throw bad_input(message({"cannot write ", what, " into '", dir, "': it is in ", pseudo,
                                 ", a kernel interface, not a place for data files"}));
}

// ---- staging_dir ----

staging_dir::staging_dir(const std::string& final_dir, std::string what) : final_(final_dir), what_(std::move(what)) {
    while (final_.size() > 1 && final_.back() == '/') final_.pop_back();
    if (final_.empty()) throw bad_input("the output directory name is empty");
    struct stat st {};
    const bool exists = ::stat(final_.c_str(), &st) == 0;
    if (exists && !S_ISDIR(st.st_mode))
        throw bad_input(message({"output directory '", final_, "' exists and is not a directory"}));
    check_data_directory(final_, what_);
    // A missing directory is staged beside its final place and renamed there whole; an existing one gets
    // its files moved in one by one. Either way nothing appears in final_dir before the commit.
    std::string temp = exists ? message({final_, "/.eci-tmp-XXXXXX"}) : temp_template(final_, ".eci-tmp-");
    if (::mkdtemp(temp.data()) == nullptr) {
        const int e = errno;
        if (!exists && e == ENOENT && ::stat(dir_of(final_).c_str(), &st) != 0)
            throw bad_input(message({"cannot create output directory '", final_, "': directory '", dir_of(final_),
                                     "' does not exist"}));
        throw bad_input(message({"cannot write into '", exists ? final_ : dir_of(final_), "': ", errno_text(e)}));
    }
    path_ = temp;
    slot_ = register_cleanup(path_, 2);
}

staging_dir::~staging_dir() {
    if (committed_) return;
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
    unregister_cleanup(slot_);
}

void staging_dir::move_in() {
    namespace fs = std::filesystem;
    const auto fail = [&](std::string_view what) {
        partly_moved_in_ = !take_back();
        return run_error(std::string(what));
    };
    struct stat st {};
    if (::stat(final_.c_str(), &st) != 0) {
        // The directory did not exist: it appears whole.
        const mode_t mask = ::umask(0);
        ::umask(mask);
        ::chmod(path_.c_str(), 0777 & ~mask);
        if (::rename(path_.c_str(), final_.c_str()) != 0)
            throw run_error(message({"cannot create output directory '", final_, "': ", errno_text()}));
        moved_whole_ = true;
        return;
    }
    std::error_code ec;
    // The names first: the replaced files are kept aside in the same directory and must not be moved.
    std::vector<fs::directory_entry> entries;
    for (const auto& entry : fs::directory_iterator(path_, ec)) entries.push_back(entry);
    if (ec) throw fail(message({"cannot read '", path_, "': ", ec.message()}));
    for (const auto& entry : entries) {
        const std::string name = entry.path().filename().string();
        // A symlinked name is written through: its target is replaced, the link kept.
        std::string target = message({final_, "/", name});
        if (std::string resolved; resolve_links(target, resolved)) target = resolved;
        struct stat old {};
        const bool existed = ::stat(target.c_str(), &old) == 0;
        if (existed && !S_ISREG(old.st_mode))
            throw fail(message({"cannot write '", target, "': it is ", kind_of(old.st_mode), ", not a regular file"}));
        if (int fd = ::open(entry.path().c_str(), O_RDONLY | O_CLOEXEC); fd >= 0) {
            const bool synced = ::fsync(fd) == 0 || errno == EINVAL;
            const int e = errno;
            ::close(fd);
            if (!synced) throw fail(message({"cannot write '", target, "': ", errno_text(e)}));
        }
        std::string backup;
        if (existed) {
            ::chmod(entry.path().c_str(), old.st_mode & 07777);
            backup = message({path_, "/.old-", name});
            if (::link(target.c_str(), backup.c_str()) != 0) backup.clear();
        }
        if (::rename(entry.path().c_str(), target.c_str()) != 0) {
            const int e = errno;
            if (!backup.empty()) ::unlink(backup.c_str());
            throw fail(message({"cannot write '", target, "': ", errno_text(e)}));
        }
        if (!existed)
            created_.push_back(target);
        else if (backup.empty())
            overwritten_.push_back(target);
        else
            replaced_.emplace_back(target, backup);
    }
}

bool staging_dir::take_back() {
    if (moved_whole_) {
        moved_whole_ = false;
        return ::rename(final_.c_str(), path_.c_str()) == 0;  // the destructor removes it
    }
    bool all = overwritten_.empty();  // their old content is gone
    for (auto it = replaced_.rbegin(); it != replaced_.rend(); ++it)
        all = ::rename(it->second.c_str(), it->first.c_str()) == 0 && all;
    for (const std::string& target : created_) all = ::unlink(target.c_str()) == 0 && all;
    replaced_.clear(), created_.clear(), overwritten_.clear();
    return all;
}

void staging_dir::finish_commit() {
    if (!moved_whole_) {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);  // the replaced files kept aside
    }
    replaced_.clear(), created_.clear(), overwritten_.clear();
    committed_ = true;
    unregister_cleanup(slot_);
}

void staging_dir::commit() {
    const std::string where = message({"before the ", what_, " were committed"});
    throw_if_interrupted(where);
    const sigset_t block = interrupt_set();
    sigset_t previous;
    ::pthread_sigmask(SIG_BLOCK, &block, &previous);
    try {
        throw_if_interrupted(where);
        try {
            move_in();
        } catch (const run_error& e) {
            if (!partly_moved_in_) throw;
            throw run_error(message({e.what(), "; some of the ", what_, " in '", final_,
                                     "' could not be given their old content back"}));
        }
        finish_commit();
    } catch (...) {
        ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
        throw;
    }
}

// ---- numbers ----

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

// ---- signals ----

void install_interrupt_handler() {
    struct sigaction sa {};
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;  // interrupted reads and writes resume; the loops poll the flag instead
    sa.sa_handler = on_interrupt;
    for (int s : handled_signals) ::sigaction(s, &sa, nullptr);
    sa.sa_handler = on_watchdog;
    ::sigaction(SIGALRM, &sa, nullptr);
    ::sigaction(SIGVTALRM, &sa, nullptr);
    // A write beyond a file size limit (ulimit -f) fails with EFBIG, as on a full disk, and takes the failure
    // path (the temporaries removed, the old files kept, the reason said); SIGXFSZ's default killed the process
    // and left the temporaries.
    sa.sa_handler = SIG_IGN;
    ::sigaction(SIGXFSZ, &sa, nullptr);
    // A parent may hand these signals over blocked (the mask survives exec): one sent since is pending, and is
    // delivered to the handler now instead of never.
    const sigset_t set = interrupt_set();
    ::sigprocmask(SIG_UNBLOCK, &set, nullptr);
}

bool interrupt_requested() { return cancel.load(std::memory_order_relaxed); }

const std::atomic<bool>* cancel_flag() { return &cancel; }

int interrupt_signal() { return cancel.load() ? static_cast<int>(signal_number) : 0; }

int interrupt_exit_status() {
    const int s = interrupt_signal();
    return 128 + (s ? s : SIGINT);
}

void throw_if_interrupted(std::string_view where) {
    if (!interrupt_requested()) return;
    std::string m = message({"interrupted by ", signal_name(interrupt_signal())});
    if (!where.empty()) m.append(" ").append(where);
    throw interrupted(m);
}

bool interrupt_keeps_outputs() { return interrupt_requested() && interrupt_signal() != SIGPIPE; }

std::string interrupt_message(std::string_view where) {
    std::string m = interrupt_requested() ? message({"interrupted by ", signal_name(interrupt_signal())})
                                          : std::string("interrupted");
    if (!where.empty()) m.append(" ").append(where);
    return m;
}

void register_child(pid_t pid) { child_pid.store(pid); }

void set_interrupt_grace(double cpu_seconds, double wall_seconds) {
    // Clamped to [default, 1 hour]: a watchdog is still a watchdog.
    const auto us = [](double s, double lo) {
        return static_cast<long long>(std::clamp(std::isfinite(s) ? s : lo, lo, 3600.0) * 1e6);
    };
    grace_cpu_us.store(us(cpu_seconds, 0.3));
    grace_wall_us.store(us(wall_seconds, 1.0));
}

std::string plotting_program() {
    const char* env = std::getenv("ECI_GNUPLOT");
    return env && *env ? env : "gnuplot";
}

std::string gnuplot_number(double v) {
    if (!std::isfinite(v)) return "NaN";
    char b[32];
    std::snprintf(b, sizeof b, "%.17g", v);
    return b;
}

std::string field_image(const std::string& data, int n, const std::vector<double>& field, const std::string& symbol) {
    write_new_file(data, "field data for gnuplot", [&](std::FILE* f) {
        std::fwrite(field.data(), sizeof(double), field.size(), f);
    });
    double big = 0.0;
    for (double v : field) big = std::max(big, std::abs(v));
    if (!(big > 0.0)) big = 1.0;
    const double h = 2.0 * M_PI / n;
    return "set xlabel 'x'\nset ylabel 'y'\nset xrange [0:2*pi]\nset yrange [0:2*pi]\nset cbrange [" +
           gnuplot_number(-big) + ":" + gnuplot_number(big) + "]\n" +
           "set palette defined (0 '#053061', 0.25 '#4393c3', 0.5 '#f7f7f7', 0.75 '#d6604d', 1 '#67001f')\n" +
           "set cblabel " + gnuplot_quoted(symbol) + "\nplot " + gnuplot_quoted(data) + " binary array=(" +
           std::to_string(n) + "," + std::to_string(n) + ") format='%float64' dx=" + gnuplot_number(h) +
           " dy=" + gnuplot_number(h) + " with image notitle\n";
}

std::string gnuplot_quoted(const std::string& s) {
    std::string q = "'";
    for (char c : s) q += c == '\'' ? std::string("''") : std::string(1, c);
    return q + "'";
}

namespace {

std::atomic<bool> plotting_timed_out{false};

}  // namespace

double plotting_time_limit() {
    const char* env = std::getenv("ECI_PLOT_TIMEOUT");
    char* end = nullptr;
    const double v = env && *env ? std::strtod(env, &end) : 0.0;
    return env && *env && *end == '\0' && v > 0.0 && std::isfinite(v) ? v : 600.0;
}

std::string plotting_failure() {
    if (!plotting_timed_out.load()) return {};
    return plotting_program() + " did not finish a picture within " + gnuplot_number(plotting_time_limit()) +
           " s ($ECI_PLOT_TIMEOUT) and was stopped";
}

bool plotting_available() {
    static const bool available = [] {
        const int status = run_program(plotting_program(), {"--version"}, true, plotting_time_limit());
        if (status == program_timed_out) plotting_timed_out.store(true);
        return status == 0;
    }();
    return available && !plotting_timed_out.load();
}

// Whether `png` ends as a PNG file ends (its IEND chunk): gnuplot's exit status does not say whether the picture was
// written whole, and on a full disk it is not.
namespace {

bool whole_png(const std::string& png) {
    static constexpr unsigned char iend[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xAE, 0x42, 0x60, 0x82};
    std::FILE* f = std::fopen(png.c_str(), "rb");
    if (!f) return false;
    unsigned char tail[12] = {};
    const bool read = std::fseek(f, -12, SEEK_END) == 0 && std::fread(tail, 1, 12, f) == 12;
    std::fclose(f);
    return read && std::memcmp(tail, iend, 12) == 0;
}

}  // namespace

// Runs a gnuplot script (written beside `output`, the picture it draws); false when gnuplot is missing, cannot draw
// (no pngcairo) or was stopped by an interrupt (which the run's loop then honours, with its checkpoint). A picture
// not written whole, or not at all, on a file system with no space left is an error like any other failed write
// (run_error, with the reason); otherwise what the program wrote is its business ($ECI_GNUPLOT may be another
// program).
bool draw_picture(const std::string& script, const std::string& output) {
    static const std::string program = plotting_program();
    if (!plotting_available()) return false;
    const scoped_temporary file(output + ".gp");
    write_new_file(file.path(), "gnuplot script", [&](std::FILE* f) { std::fputs(script.c_str(), f); });
    const int status = run_program(program, {file.path()}, true, plotting_time_limit());
    if (status == -1) return false;
    if (status == program_timed_out) {
        plotting_timed_out.store(true);
        return false;
    }
    if (status == 0 && whole_png(output)) return true;
    if (const std::string reason = write_failure_reason(output, 0, ""); !reason.empty())
        throw run_error("cannot write picture '" + output + "': " + reason);
    return status == 0;
}


int run_program(const std::string& program, const std::vector<std::string>& args, bool quiet, double time_limit) {
    std::fflush(stdout);
    std::fflush(stderr);
    std::vector<const char*> argv{program.c_str()};
    for (const std::string& a : args) argv.push_back(a.c_str());
    argv.push_back(nullptr);
    const pid_t pid = ::fork();
    if (pid < 0) return 127;
    if (pid == 0) {
        ::setpgid(0, 0);
        // The parent's handlers are not the child's business: default dispositions, nothing blocked.
        for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE, SIGALRM, SIGVTALRM}) std::signal(sig, SIG_DFL);
        sigset_t none;
        sigemptyset(&none);
        ::sigprocmask(SIG_SETMASK, &none, nullptr);
        const int null = ::open("/dev/null", quiet ? O_RDWR : O_RDONLY);
        if (null >= 0) {
            ::dup2(null, STDIN_FILENO);  // nothing to read: a program that asks does not wait on our terminal
            if (quiet) ::dup2(null, STDOUT_FILENO), ::dup2(null, STDERR_FILENO);
        }
        ::execvp(argv[0], const_cast<char* const*>(argv.data()));
        ::_exit(127);
    }
    ::setpgid(pid, pid);  // also here, so that the group exists before the first kill
    register_child(pid);
    int status = 0;
    const auto started = std::chrono::steady_clock::now();
    for (;;) {
        const pid_t w = ::waitpid(pid, &status, WNOHANG);
        if (w == pid) break;
        const bool lost = w < 0 && errno != EINTR;
        const bool late = time_limit > 0.0 &&
                          std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() > time_limit;
        if (lost || late || interrupt_requested()) {
            ::kill(-pid, SIGKILL);
            while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
            }
            register_child(0);
            return interrupt_requested() ? -1 : late ? program_timed_out : 127;
        }
        ::usleep(10000);  // 10 ms: an interrupt is seen within that, at no measurable cost
    }
    register_child(0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

created_directory::created_directory(std::string path) : path_(std::move(path)), slot_(register_cleanup(path_, 3)) {}

created_directory::~created_directory() {
    if (!path_.empty()) ::rmdir(path_.c_str());
    unregister_cleanup(slot_);
}

void created_directory::keep() {
    unregister_cleanup(slot_);
    slot_ = -1;
    path_.clear();
}

scoped_temporary::scoped_temporary(std::string path) : path_(std::move(path)), slot_(register_cleanup(path_, 1)) {}

scoped_temporary::~scoped_temporary() {
    std::error_code ec;
    std::filesystem::remove(path_, ec);
    unregister_cleanup(slot_);
}

// ---- a status line while something slow runs ----

delayed_status::delayed_status(std::string text, std::chrono::milliseconds after) {
    if (::isatty(STDERR_FILENO) != 1) return;
    waiter_ = std::thread([this, text = std::move(text), after] {
        std::unique_lock<std::mutex> lock(mutex_);
        if (done_cv_.wait_for(lock, after, [this] { return done_; })) return;
        std::fputs(("\r" + text).c_str(), stderr);
        std::fflush(stderr);
        shown_ = true;
        status_line_on.store(true);
    });
}

delayed_status::~delayed_status() {
    if (!waiter_.joinable()) return;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        done_ = true;
    }
    done_cv_.notify_all();
    waiter_.join();
    if (!shown_) return;
    std::fputs("\r\033[K", stderr);
    std::fflush(stderr);
    status_line_on.store(false);
}

// ---- progress bar ----

progress_bar::progress_bar(std::uint64_t total, std::uint64_t check_every, double t_end)
    : total_(total),
      check_every_(check_every == 0 ? 1 : check_every),
      t_end_(t_end),
      enabled_(::isatty(STDERR_FILENO) == 1) {}

void progress_bar::draw(std::uint64_t i, double t, const std::string& detail) {
    shown_ = true;
    const double fraction = total_ ? double(i) / double(total_) : t_end_ > 0.0 ? t / t_end_ : 1.0;
    std::fprintf(stderr, "\r%s %s", progress_text(fraction, t, pace_.elapsed()).c_str(), detail.c_str());
    std::fflush(stderr);
}

void progress_bar::finish() {
    if (!shown_) return;
    std::fputs("\r\033[K", stderr);
    std::fflush(stderr);
    shown_ = false;
}

}  // namespace eci::cli

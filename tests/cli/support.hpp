// Helpers shared by the CLI tests: run the real `eci` binary (ECI_CLI_PATH) through the shell with its exit
// status, stdout and stderr captured, read files back, split CSV lines, and own a scratch directory.
#pragma once

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace eci::test_cli {

namespace fs = std::filesystem;

/// What one run of the binary did: exit status (-1 if it did not exit normally), stdout, stderr.
struct run_result {
    int status = -1;
    std::string out, err;
};

/// The whole content of a file, byte for byte ("" if it cannot be read).
inline std::string read_text(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// The lines of a text, without their '\n'.
inline std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
}

/// The fields of one line split at `sep` (a trailing empty field is dropped, as std::getline does).
inline std::vector<std::string> split(const std::string& line, char sep = ',') {
    std::vector<std::string> parts;
    std::istringstream in(line);
    for (std::string part; std::getline(in, part, sep);) parts.push_back(part);
    return parts;
}

/// Why `text` is not a complete CSV (a header and rows of as many fields, each ending in a newline), or "" if it is:
/// what an interrupted run keeps must never end in a half-written row.
inline std::string incomplete_csv(const std::string& text) {
    if (text.empty() || text.back() != '\n') return "the last row is cut";
    const auto lines = lines_of(text);
    const std::size_t width = split(lines.front()).size();
    for (const std::string& line : lines)
        if (split(line).size() != width) return "row '" + line + "' has not the header's " + std::to_string(width) +
                                                " fields";
    return "";
}

/// Why `text` is not a complete JSON summary of an interrupted run, or "" if it is.
inline std::string incomplete_interrupted_json(const std::string& text) {
    if (text.rfind("{\n", 0) != 0 || text.size() < 4 || text.substr(text.size() - 4) != "}\n}\n") return "cut";
    if (text.find("\"interrupted\": true") == std::string::npos) return "no \"interrupted\": true";
    return "";
}

/// `s` single-quoted for the shell.
inline std::string shell_quote(const std::string& s) {
    // Appends only: GCC 12 warns (-Wrestrict, falsely) on some operator+ chains of literals and strings.
    std::string q = "'";
    for (char c : s) {
        if (c == '\'')
            q.append("'\\''");
        else
            q.push_back(c);
    }
    q.push_back('\'');
    return q;
}

/// Runs `prefix eci shell_args` through the shell (stdin from /dev/null); stdout and stderr go through the files
/// out and err in `capture_dir`, so the directory eci writes into holds only what eci itself wrote.
inline run_result run_eci(const std::string& shell_args, const fs::path& capture_dir, const std::string& prefix = "") {
    const fs::path out = capture_dir / "out", err = capture_dir / "err";
    std::string cmd = prefix;
    cmd.append(" ").append(shell_quote(ECI_CLI_PATH)).append(" ").append(shell_args);
    cmd.append(" </dev/null >").append(shell_quote(out.string())).append(" 2>").append(shell_quote(err.string()));
    const int raw = std::system(cmd.c_str());
    run_result r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = read_text(out);
    r.err = read_text(err);
    fs::remove(out);
    fs::remove(err);
    return r;
}

/// The signal state a parent hands to eci: default dispositions and nothing blocked; SIGINT and SIGQUIT ignored
/// (what a shell's `cmd &` does without job control); or every signal blocked, SIGINT and SIGQUIT also ignored.
enum class handed_signals { defaults, interrupts_ignored, all_blocked };

/// Starts eci with `args` in `dir` (stdin and stdout /dev/null, stderr to `err_file`, no core dumps) without a
/// shell, so that a signal can be sent the moment it exists; returns its pid. With all_blocked the signals are
/// blocked in this process already before the fork: one sent at once is pending in the child, never delivered
/// to anything but eci.
inline pid_t start_eci(const fs::path& dir, const std::vector<std::string>& args, const fs::path& err_file,
                       handed_signals how = handed_signals::defaults) {
    std::vector<std::string> words{ECI_CLI_PATH};
    words.insert(words.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& w : words) argv.push_back(w.data());
    argv.push_back(nullptr);
    // all_blocked: the child inherits the mask and the ignored SIGINT and SIGQUIT from this process, set before
    // the fork (setting SIG_IGN in the child would discard a signal already pending there).
    sigset_t all, previous;
    sigfillset(&all);
    struct sigaction ignore {}, saved_int {}, saved_quit {};
    ignore.sa_handler = SIG_IGN;
    if (how == handed_signals::all_blocked) {
        ::sigprocmask(SIG_BLOCK, &all, &previous);
        ::sigaction(SIGINT, &ignore, &saved_int);
        ::sigaction(SIGQUIT, &ignore, &saved_quit);
    }
    const pid_t pid = ::fork();
    if (pid == 0) {  // (async-signal-safe calls only until exec)
        for (int s : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE}) {
            const bool ignored = how != handed_signals::defaults && (s == SIGINT || s == SIGQUIT);
            if (ignored && how == handed_signals::all_blocked) continue;  // inherited
            struct sigaction sa {};
            sa.sa_handler = ignored ? SIG_IGN : SIG_DFL;
            ::sigaction(s, &sa, nullptr);
        }
        if (how != handed_signals::all_blocked) {
            sigset_t none;
            sigemptyset(&none);
            ::sigprocmask(SIG_SETMASK, &none, nullptr);
        }
        const rlimit no_core{0, 0};
        ::setrlimit(RLIMIT_CORE, &no_core);
        const int in = ::open("/dev/null", O_RDWR), err = ::open(err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (in < 0 || err < 0 || ::chdir(dir.c_str()) != 0) ::_exit(126);
        ::dup2(in, 0), ::dup2(in, 1), ::dup2(err, 2);
        ::execv(argv[0], argv.data());
        ::_exit(127);
    }
    if (how == handed_signals::all_blocked) {
        ::sigaction(SIGINT, &saved_int, nullptr);
        ::sigaction(SIGQUIT, &saved_quit, nullptr);
        ::sigprocmask(SIG_SETMASK, &previous, nullptr);
    }
    return pid;
}

/// How a started process ended: `raw` is waitpid's status, `seconds` the time from the call to its end; a process
/// still there after `limit` seconds is killed (SIGKILL) and `hung` set.
struct ending {
    int raw = 0;
    double seconds = 0.0;
    bool hung = false;
};
inline ending wait_at_most(pid_t pid, double limit) {
    const auto start = std::chrono::steady_clock::now();
    ending e;
    for (;;) {
        e.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (::waitpid(pid, &e.raw, WNOHANG) == pid) return e;
        if (e.seconds > limit) {
            e.hung = true;
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &e.raw, 0);
            return e;
        }
        ::usleep(2000);
    }
}

/// Whether signal `s` is in the mask of process `pid` named `field` in its /proc status ("SigCgt:": it has a
/// handler; "SigBlk:": it blocks it).
inline bool signal_in(pid_t pid, const std::string& field, int s) {
    std::ifstream status("/proc/" + std::to_string(pid) + "/status");
    for (std::string line; std::getline(status, line);)
        if (line.rfind(field, 0) == 0) return (std::stoull(line.substr(field.size()), nullptr, 16) >> (s - 1)) & 1;
    return false;
}
inline bool catches(pid_t pid, int s) { return signal_in(pid, "SigCgt:", s); }

/// A fresh, uniquely named directory under the system temp dir, removed with everything in it on destruction.
class scratch_dir {
   public:
    explicit scratch_dir(const std::string& tag) {
        std::string pattern = (fs::temp_directory_path() / ("eci-" + tag + "-XXXXXX")).string();
        if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("cannot create a temp dir " + pattern);
        path_ = pattern;
    }
    scratch_dir(const scratch_dir&) = delete;
    scratch_dir& operator=(const scratch_dir&) = delete;
    ~scratch_dir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }

    /// The directory itself.
    const fs::path& path() const { return path_; }

   private:
    fs::path path_;
};

/// A test's own tree: eci runs in work/ (where every output goes) and its stdout and stderr are captured in
/// capture/, so work/ holds only what eci itself wrote. Removed with everything in it on destruction.
class work_dir {
   public:
    explicit work_dir(const std::string& tag) : scratch_(tag), work_(scratch_.path() / "work") {
        fs::create_directory(work_);
        fs::create_directory(capture());
    }

    /// Runs `wrapper eci shell_args` in work/ (shell_args already quoted; wrapper a prefix such as timeout).
    run_result run(const std::string& shell_args, const std::string& wrapper = "") const {
        std::string prefix = "cd ";
        prefix.append(shell_quote(work_.string())).append(" && ").append(wrapper);
        return run_eci(shell_args, capture(), prefix);
    }

    /// Runs eci with each of `args` quoted as one word.
    run_result run(const std::vector<std::string>& args, const std::string& wrapper = "") const {
        std::string quoted;
        for (const std::string& a : args) quoted.append(" ").append(shell_quote(a));
        return run(quoted, wrapper);
    }

    /// work/ itself, and a file in it.
    const fs::path& path() const { return work_; }
    fs::path file(const std::string& name) const { return work_ / name; }

    /// Where stdout and stderr (and any other capture) go.
    fs::path capture() const { return scratch_.path() / "capture"; }

    /// The names of the files in work/ (hidden ones included), sorted.
    std::set<std::string> files() const {
        std::set<std::string> names;
        for (const auto& e : fs::directory_iterator(work_)) names.insert(e.path().filename().string());
        return names;
    }

    /// Empties work/ (for a loop of runs in one tree).
    void clear() const {
        for (const auto& e : fs::directory_iterator(work_)) fs::remove_all(e.path());
    }

   private:
    scratch_dir scratch_;
    fs::path work_;
};

}  // namespace eci::test_cli

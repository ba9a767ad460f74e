// The `eci` command as started: blocks the interrupt signals and runs the tool itself, eci-main beside it, in the
// same process (exec). Why: before a program's first instruction the dynamic loader maps its libraries (eci-main
// needs some forty, HDF5's among them: tens of milliseconds, more under load or a sanitizer), and a signal that
// arrives then finds the disposition the parent left: the default kills the process, an ignored SIGINT (a shell's
// `cmd &`) is dropped. This program is linked statically and does nothing before blocking them, so that window
// shrinks to its own start; from then on a signal stays pending across the exec until eci-main's handler, installed
// before its libraries' constructors (main.cpp), unblocks it and honours it: exit 128 + N, nothing left behind.
// C library calls only: nothing here may need the dynamic loader or a constructor.
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstring>
#include <initializer_list>

#include <unistd.h>

namespace {

void say(const char* s) {
    const ssize_t ignored = ::write(STDERR_FILENO, s, std::strlen(s));
    (void)ignored;
}

}  // namespace

int main(int, char** argv) {
    sigset_t interrupts;
    sigemptyset(&interrupts);
    for (int s : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE}) sigaddset(&interrupts, s);
    ::sigprocmask(SIG_BLOCK, &interrupts, nullptr);

    // eci-main in this program's own directory (symlinks to it resolved by the kernel's /proc/self/exe).
    char path[PATH_MAX];
    ssize_t n = ::readlink("/proc/self/exe", path, sizeof path - 16);
    while (n > 0 && path[n - 1] != '/') --n;
    if (n <= 0) {
        say("eci: error: cannot find this program's directory (/proc/self/exe)\n");
        return 1;
    }
    std::strcpy(path + n, "eci-main");
    ::execv(path, argv);
    const int e = errno;
    say("eci: error: cannot start ");
    say(path);
    say(": ");
    say(std::strerror(e));
    say("\n");
    return 1;
}

// Every file the spectral commands write (checkpoint, snapshots, spectra, pictures, FFTW wisdom) goes through
// the CLI's one output path. Each class of defect with several members: special files refused or written
// through, no hang on a FIFO or device, no temporaries left, unwritable or colliding outputs refused before the
// run, failed runs create or replace nothing, full disks reported, never committed.
#ifdef ECI_CLI_PATH

#include <gtest/gtest.h>
#include <hdf5.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include "cli/support.hpp"

namespace {

using namespace eci::test_cli;

// A short run that would take minutes if it started: a refusal "before any work" must come at once.
const std::string endless = "run navier-stokes-2d --N 16 --steps 100000000 --fftw-estimate ";
const std::string small = "run navier-stokes-2d --N 16 --steps 2 --fftw-estimate ";
const std::string blow_up = "run navier-stokes-2d --N 32 --method euler --cfl 2 --steps 500 --fftw-estimate ";

// Runs under a 30 s timeout (a hang shows as status 124) with HOME and XDG_CACHE_HOME in the scratch tree.
run_result run_in(const work_dir& w, const std::string& args) {
    const std::string home = shell_quote((w.capture() / "home").string());
    return w.run(args, "HOME=" + home + " XDG_CACHE_HOME=" + home + "/cache timeout 30 ");
}

void expect_refused(const run_result& r, const std::string& what) {
    EXPECT_EQ(r.status, 2) << what << ": " << r.err;
    EXPECT_EQ(lines_of(r.err).size(), 1u) << what << ": " << r.err;
    EXPECT_EQ(r.err.rfind("eci: error: ", 0), 0u) << what << ": " << r.err;
}

// The names in a directory (and its subdirectories) that look like temporaries.
std::vector<std::string> temporaries(const fs::path& dir) {
    std::vector<std::string> found;
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.find(".tmp") != std::string::npos || name.find("eci-tmp") != std::string::npos ||
            name.find("eci-old") != std::string::npos || name.find(".bin") != std::string::npos)
            found.push_back(it->path().string());
    }
    return found;
}

void write_text(const fs::path& f, const std::string& text) {
    std::ofstream o(f);
    o << text;
}

// The special files a test puts where an output goes: name -> how to make it (false: not permitted here).
struct special {
    const char* name;
    bool (*make)(const fs::path&);
};
const special specials[] = {
    {"FIFO", [](const fs::path& p) { return ::mkfifo(p.c_str(), 0644) == 0; }},
    {"/dev/null copy", [](const fs::path& p) { return ::mknod(p.c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0; }},
    {"/dev/full copy", [](const fs::path& p) { return ::mknod(p.c_str(), S_IFCHR | 0666, makedev(1, 7)) == 0; }},
    {"directory", [](const fs::path& p) { return fs::create_directory(p); }},
    {"read-only file",
     [](const fs::path& p) {
         write_text(p, "precious\n");
         fs::permissions(p, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
         return true;
     }},
    {"symlink to a FIFO",
     [](const fs::path& p) {
         const fs::path fifo = p.parent_path() / "the-fifo";
         return ::mkfifo(fifo.c_str(), 0644) == 0 && ::symlink("the-fifo", p.c_str()) == 0;
     }},
};

// What a special file looked like, to check it is still there, unchanged.
std::string describe(const fs::path& p) {
    struct stat st {};
    if (::lstat(p.c_str(), &st) != 0) return "missing";
    std::string d = std::to_string(st.st_mode) + ":" + std::to_string(st.st_rdev);
    if (S_ISREG(st.st_mode)) d += ":" + read_text(p);
    return d;
}

// Special files, no hang: a FIFO, a device, a directory, a read-only file or a link to a FIFO as --checkpoint,
// --fftw-wisdom or an existing snapshot name: one line, exit 2, before any work, no hang, the file untouched.
TEST(CliSpectralOutputs, SpecialFilesAreRefusedBeforeAnyWorkNeverReplaced) {
    work_dir w("spectral-special");
    int tried = 0;
    for (const special& s : specials) {
        for (const std::string role : {"checkpoint", "wisdom", "snapshot h5", "snapshot csv", "snapshot png"}) {
            w.clear();
            fs::create_directory(w.file("snaps"));
            fs::path target;
            std::string args;
            if (role == "checkpoint") {
                target = w.file("ck.h5");
                args = "--checkpoint ck.h5 --checkpoint-every 1";
            } else if (role == "wisdom") {
                target = w.file("w");
                args = "--fftw-wisdom w";
            } else {
                target = w.file("snaps") / (role == "snapshot h5"    ? "vorticity_00000000.h5"
                                            : role == "snapshot csv" ? "spectrum_00000000.csv"
                                                                     : "vorticity_00000001.png");
                args = "--snapshot-every 1 --snapshot-dir snaps";
            }
            if (!s.make(target)) {
                std::cout << "note: not tested: " << s.name << " as " << role << ": cannot be made here\n";
                continue;
            }
            ++tried;
            const std::string before = describe(target);
            const run_result r = run_in(w, endless + args + " --output out.csv");
            expect_refused(r, std::string(s.name) + " as " + role);
            EXPECT_EQ(describe(target), before) << s.name << " as " << role;
            EXPECT_FALSE(fs::exists(w.file("out.csv"))) << s.name << " as " << role;
            EXPECT_TRUE(temporaries(w.path()).empty()) << s.name << " as " << role;
        }
    }
    EXPECT_GE(tried, 15);
}

// A symlink to a regular file is written through: the link stays, its target gets the new content.
TEST(CliSpectralOutputs, SymlinksToRegularFilesAreWrittenThrough) {
    work_dir w("spectral-symlink");
    fs::create_directory(w.file("elsewhere"));
    fs::create_directory(w.file("snaps"));
    for (const char* f : {"ck.h5", "vorticity_00000002.h5", "spectrum_00000002.csv"})
        write_text(w.file("elsewhere") / f, "old\n");
    write_text(w.file("elsewhere") / "w", "");  // (a wisdom file that is not wisdom would be refused, not replaced)
    fs::create_symlink("elsewhere/ck.h5", w.file("ck.h5"));
    fs::create_symlink("elsewhere/w", w.file("w"));
    fs::create_symlink("../elsewhere/vorticity_00000002.h5", w.file("snaps") / "vorticity_00000002.h5");
    fs::create_symlink("../elsewhere/spectrum_00000002.csv", w.file("snaps") / "spectrum_00000002.csv");
    const run_result r = run_in(w, small + "--fftw-wisdom w --checkpoint ck.h5 --checkpoint-every 2 "
                                           "--snapshot-every 1 --snapshot-dir snaps");
    ASSERT_EQ(r.status, 0) << r.err;
    for (const fs::path& link : {w.file("ck.h5"), w.file("w"), w.file("snaps") / "vorticity_00000002.h5",
                                w.file("snaps") / "spectrum_00000002.csv"}) {
        EXPECT_TRUE(fs::is_symlink(link)) << link;
        EXPECT_NE(read_text(link), "old\n") << link;
        EXPECT_GT(fs::file_size(link), 4u) << link;
    }
    EXPECT_EQ(read_text(w.file("snaps") / "spectrum_00000002.csv").rfind("k,E,Z", 0), 0u);
    EXPECT_TRUE(temporaries(w.path()).empty());
    // the restart reads the checkpoint through the link
    EXPECT_EQ(run_in(w, "run navier-stokes-2d --restart ck.h5 --steps 3 --checkpoint ck2.h5").status, 0);
}

// Outputs that cannot be written are refused before the run (the endless run would time out).
TEST(CliSpectralOutputs, UnwritableOutputsAreRefusedBeforeTheRun) {
    work_dir w("spectral-unwritable");
    write_text(w.file("plain"), "x\n");
    std::vector<std::string> cases = {
        "--checkpoint nodir/ck.h5",
        "--checkpoint plain/ck.h5",
        "--checkpoint /proc/self/ck.h5",
        "--checkpoint -",
        "--checkpoint ck.h5/",
        "--checkpoint " + std::string(300, 'c') + ".h5",
        "--fftw-wisdom nodir/w",
        "--fftw-wisdom plain/w",
        "--snapshot-every 1 --snapshot-dir nodir/snaps",
        "--snapshot-every 1 --snapshot-dir plain",
    };
    if (::geteuid() != 0) {  // root writes into read-only directories: only a non-root run can show these
        fs::create_directory(w.file("ro"));
        fs::permissions(w.file("ro"), fs::perms::owner_read | fs::perms::owner_exec);
        cases.push_back("--checkpoint ro/ck.h5");
        cases.push_back("--snapshot-every 1 --snapshot-dir ro");
        cases.push_back("--fftw-wisdom ro/w");
    } else {
        std::cout << "note: not tested: read-only directories: running as root, which may write into them\n";
    }
    for (const std::string& args : cases) {
        const run_result r = run_in(w, endless + args + " --output out.csv");
        expect_refused(r, args);
        EXPECT_FALSE(fs::exists(w.file("out.csv"))) << args;
        EXPECT_FALSE(fs::exists(w.file("nodir"))) << args;
        EXPECT_TRUE(temporaries(w.path()).empty()) << args;
    }
    if (::geteuid() != 0) fs::permissions(w.file("ro"), fs::perms::owner_all);
}

// Colliding outputs: two outputs that are one file, by name, through a symlink, a dangling symlink or a hard link.
TEST(CliSpectralOutputs, CollidingOutputsAreRefused) {
    work_dir w("spectral-collide");
    fs::create_directory(w.file("snaps"));
    write_text(w.file("existing.csv"), "precious\n");
    fs::create_hard_link(w.file("existing.csv"), w.file("hard.h5"));
    fs::create_symlink("o.csv", w.file("dangling.h5"));     // o.csv does not exist
    fs::create_symlink("o.csv", w.file("dangling.json"));
    fs::create_symlink("existing.csv", w.file("link.h5"));
    const std::vector<std::string> cases = {
        "--checkpoint o.csv --output o.csv",
        "--checkpoint ./o.csv --output o.csv",
        "--checkpoint dangling.h5 --output o.csv",
        "--checkpoint link.h5 --output existing.csv",
        "--checkpoint hard.h5 --output existing.csv",
        "--fftw-wisdom o.csv --output o.csv",
        "--fftw-wisdom ck.h5 --checkpoint ck.h5",
        "--summary-json dangling.json --output o.csv",
        "--summary-json o.csv --checkpoint dangling.h5",
        "--checkpoint snaps/vorticity_00000000.h5 --snapshot-every 1 --snapshot-dir snaps",
        "--output snaps/spectrum_00000004.csv --snapshot-every 4 --snapshot-dir snaps",
        "--checkpoint snaps --snapshot-every 4 --snapshot-dir snaps",
        "--checkpoint new-snaps --snapshot-every 4 --snapshot-dir new-snaps",
    };
    for (const std::string& args : cases) {
        const run_result r = run_in(w, endless + args);
        expect_refused(r, args);
        EXPECT_TRUE(r.err.find("same file") != std::string::npos || r.err.find("is a directory") != std::string::npos)
            << args << ": " << r.err;
        EXPECT_FALSE(fs::exists(w.file("o.csv"))) << args;
        EXPECT_EQ(read_text(w.file("existing.csv")), "precious\n") << args;
    }
    // the same for the other models' --output and --summary-json
    const run_result r = run_in(w, "run kepler --steps 10 --output o.csv --summary-json dangling.json");
    expect_refused(r, "kepler through a dangling symlink");
    EXPECT_FALSE(fs::exists(w.file("o.csv")));
}

// --fftw-wisdom names a file the run reads and writes back: an existing file that is not wisdom (a CSV named by
// mistake) was replaced by the run's wisdom. It is refused, untouched; wisdom (of any FFTW version), an empty file
// and a new name are taken; a default cache holding something else is left alone with a warning.
TEST(CliSpectralOutputs, AFileThatIsNotWisdomIsNotReplaced) {
    work_dir w("spectral-not-wisdom");
    const fs::path home = w.capture() / "home";
    fs::create_directory(home);
    write_text(w.file("data.csv"), "t,energy\n0,1\n");
    const run_result r = run_in(w, small + "--fftw-wisdom data.csv");
    expect_refused(r, "a CSV as wisdom");
    EXPECT_NE(r.err.find("--fftw-wisdom 'data.csv' is not an FFTW wisdom file"), std::string::npos) << r.err;
    EXPECT_EQ(read_text(w.file("data.csv")), "t,energy\n0,1\n");
    // taken: wisdom of another FFTW version (kept as wisdom, rewritten), an empty file, a new name
    write_text(w.file("old"), "(fftw-3.3.8 fftw_wisdom #x4be12fff #x7b2df9b2 #xa5975329 #x385b0041\n)\n");
    write_text(w.file("empty"), "");
    for (const std::string f : {"old", "empty", "new"}) {
        ASSERT_EQ(run_in(w, small + "--fftw-wisdom " + f).status, 0) << f;
        EXPECT_EQ(read_text(w.file(f)).rfind("(fftw-3", 0), 0u) << f;
    }
    // the default cache holding something else: the run goes on, says so, and leaves the file as it was
    fs::create_directories(home / "cache" / "eci");
    write_text(home / "cache" / "eci" / "fftw-wisdom", "not wisdom\n");
    const run_result d = run_in(w, small);
    EXPECT_EQ(d.status, 0) << d.err;
    EXPECT_NE(d.err.find("is not FFTW wisdom: the run neither reads nor replaces it"), std::string::npos) << d.err;
    EXPECT_EQ(read_text(home / "cache" / "eci" / "fftw-wisdom"), "not wisdom\n");
}

// A refused run creates no wisdom file and no cache directory; a blow-up creates and replaces no snapshot.
TEST(CliSpectralOutputs, FailedRunsCreateOrReplaceNothing) {
    work_dir w("spectral-failed");
    const fs::path home = w.capture() / "home";
    fs::create_directory(home);
    for (const std::string args : {"--energy 0", "--N 7", "--nu -1", "--forcing nonsense", "--ic missing.h5"}) {
        expect_refused(run_in(w, small + args), args);
        expect_refused(run_in(w, small + args + " --fftw-wisdom w"), args);
        EXPECT_FALSE(fs::exists(home / "cache")) << args;
        EXPECT_FALSE(fs::exists(w.file("w"))) << args;
        EXPECT_TRUE(w.files().empty()) << args;
    }
    // a good run writes the default cache (the control)
    ASSERT_EQ(run_in(w, small).status, 0);
    EXPECT_TRUE(fs::is_regular_file(home / "cache" / "eci" / "fftw-wisdom"));
    w.clear();

    // an earlier good run's snapshots and checkpoint survive a blow-up byte for byte; nothing is added
    fs::create_directory(w.file("snaps"));
    ASSERT_EQ(run_in(w, "run navier-stokes-2d --N 32 --method euler --dt 0.001 --steps 4 --fftw-estimate "
                        "--snapshot-every 1 --snapshot-dir snaps")
                  .status,
              0);
    std::vector<std::pair<fs::path, std::string>> before;
    for (const auto& e : fs::directory_iterator(w.file("snaps"))) before.emplace_back(e.path(), read_text(e.path()));
    ASSERT_GE(before.size(), 10u);
    for (const std::string dir : {"snaps", "new-snaps"}) {
        const run_result r = run_in(w, blow_up + "--snapshot-every 1 --snapshot-dir " + dir + " --output ts.csv");
        EXPECT_EQ(r.status, 1) << r.err;
        EXPECT_NE(r.err.find("blow-up"), std::string::npos) << r.err;
    }
    EXPECT_FALSE(fs::exists(w.file("new-snaps")));
    EXPECT_FALSE(fs::exists(w.file("ts.csv")));
    std::size_t count = 0;
    for (const auto& e : fs::directory_iterator(w.file("snaps"))) {
        (void)e;
        ++count;
    }
    EXPECT_EQ(count, before.size());
    for (const auto& [f, text] : before) EXPECT_EQ(read_text(f), text) << f;
    EXPECT_TRUE(temporaries(w.path()).empty());
}

// A run's outputs are committed in order, snapshots first and the CSV and JSON that describe the run last, and a
// failure while committing (an output turned into a directory during the run) takes back what was moved in: the
// earlier run's set stays whole, byte for byte, exit 1, and the one-line error names the output and says that no
// output was replaced.
TEST(CliSpectralOutputs, AFailedCommitLeavesTheEarlierRunsOutputs) {
    work_dir w("spectral-commit");
    const fs::path err = w.capture() / "err";
    const std::string outputs = " --snapshot-every 1000 --snapshot-dir snaps --output o.csv --summary-json o.json";
    // the earlier run: snapshots at steps 0 and 1000 (the later run's names too, of the same grid: another grid's
    // are refused) and its CSV and JSON
    ASSERT_EQ(run_in(w, "run navier-stokes-2d --N 64 --steps 1000 --fftw-estimate --fftw-wisdom none" + outputs)
                  .status,
              0);
    std::map<fs::path, std::string> before;
    for (const auto& e : fs::recursive_directory_iterator(w.path())) before[e.path()] = read_text(e.path());
    ASSERT_GE(before.size(), 7u);  // o.csv, o.json, snaps, 2 x (.h5, spectrum .csv)
    // the later run: other numbers (another seed), more snapshots (2000, 3000: names that did not exist)
    const std::vector<std::string> later{"run", "navier-stokes-2d", "--N", "64", "--steps", "3000", "--seed", "7",
                                         "--fftw-estimate", "--fftw-wisdom", "none", "--snapshot-every", "1000",
                                         "--snapshot-dir", "snaps", "--output", "o.csv", "--summary-json", "o.json"};
    for (const std::string sabotaged : {"snaps/vorticity_00001000.h5", "snaps/spectrum_00000000.csv", "o.csv",
                                        "o.json"}) {
        const pid_t pid = start_eci(w.path(), later, err);
        ASSERT_GT(pid, 0);
        // once the run is under way (its first snapshot is staged: the staging directory is made before the CSV
        // and JSON outputs are opened, and a directory there then is bad input, exit 2), the output becomes a
        // directory
        bool staged = false;
        for (int i = 0; i < 20000 && !staged; ++i) {
            std::error_code gone;  // (a staging directory may vanish while it is looked at)
            for (const auto& e : fs::directory_iterator(w.file("snaps")))
                staged = staged || (e.path().filename().string().rfind(".eci-tmp-", 0) == 0 &&
                                    !fs::is_empty(e.path(), gone) && !gone);
            if (!staged) ::usleep(1000);
        }
        ASSERT_TRUE(staged) << sabotaged;
        const fs::path target = w.file(sabotaged);
        const std::string kept = read_text(target);
        fs::remove(target);
        fs::create_directory(target);
        const ending end = wait_at_most(pid, 60.0);
        const std::string message = read_text(err);
        ASSERT_FALSE(end.hung) << sabotaged;
        EXPECT_TRUE(WIFEXITED(end.raw) && WEXITSTATUS(end.raw) == 1) << sabotaged << ": " << end.raw << " " << message;
        EXPECT_EQ(lines_of(message).size(), 1u) << message;
        EXPECT_NE(message.find("cannot write"), std::string::npos) << message;
        EXPECT_NE(message.find(fs::path(sabotaged).filename().string()), std::string::npos) << message;
        EXPECT_NE(message.find("; no output was replaced"), std::string::npos) << message;
        // everything else is the earlier run's, and nothing was added
        fs::remove(target);
        std::ofstream(target, std::ios::binary) << kept;
        std::map<fs::path, std::string> after;
        for (const auto& e : fs::recursive_directory_iterator(w.path())) after[e.path()] = read_text(e.path());
        EXPECT_EQ(after.size(), before.size()) << sabotaged;
        for (const auto& [f, text] : before) EXPECT_TRUE(after.count(f) && after[f] == text) << sabotaged << ": " << f;
    }
}

// No temporary is left after a failure, an interrupt while snapshots are written, or two quick signals.
TEST(CliSpectralOutputs, NoTemporariesLeftAfterFailuresAndSignals) {
    work_dir w("spectral-temps");
    // a wisdom file that is a directory: refused (it used to leave w.tmp... even on success)
    fs::create_directory(w.file("w"));
    expect_refused(run_in(w, small + "--fftw-wisdom w"), "wisdom directory");
    EXPECT_TRUE(temporaries(w.path()).empty());
    fs::remove(w.file("w"));
    // a blow-up with snapshots and checkpoints every step
    EXPECT_EQ(run_in(w, blow_up + "--snapshot-every 1 --snapshot-dir snaps --checkpoint-every 1 --checkpoint c.h5")
                  .status,
              1);
    EXPECT_TRUE(temporaries(w.path()).empty());
    // SIGINT while snapshots are written every step: exit 130, the checkpoint written, no temporary
    const std::string busy = "run navier-stokes-2d --N 64 --steps 100000000 --fftw-estimate --snapshot-every 1 "
                             "--snapshot-dir snaps --checkpoint c.h5 --fftw-wisdom w";
    run_result r = w.run(busy, "timeout --preserve-status -s INT 2 ");
    EXPECT_EQ(r.status, 130) << r.err;
    EXPECT_TRUE(fs::is_regular_file(w.file("c.h5")));
    EXPECT_TRUE(temporaries(w.path()).empty());
    // two signals in quick succession (the second forces the exit), several delays
    for (const char* delay : {"0.5", "1", "1.5"}) {
        // sh -c SCRIPT ECI ARGS...: $0 is eci
        const std::string script = std::string("\"$0\" \"$@\" & p=$!; sleep ") + delay +
                                   "; kill -INT $p; sleep 0.25; kill -TERM $p; wait $p";
        r = w.run(busy, "sh -c " + shell_quote(script) + " ");
        EXPECT_TRUE(r.status == 130 || r.status == 143) << r.status << " " << r.err;
        EXPECT_TRUE(temporaries(w.path()).empty()) << delay;
    }
}

// A full disk (a small tmpfs) is an error naming the file; the good checkpoint is kept, nothing partial
// is committed and no temporary is left. Skipped where tmpfs cannot be mounted.
TEST(CliSpectralOutputs, FullDiskIsAnErrorAndCommitsNothing) {
    work_dir w("spectral-full");
    const fs::path m = w.file("m");
    fs::create_directory(m);
    if (::mount("tmpfs", m.c_str(), "tmpfs", 0, "size=96k") != 0) {
        GTEST_SKIP() << "cannot mount a tmpfs here (not root or not permitted): full-disk cases not run";
    }
    struct unmount {
        fs::path m;
        ~unmount() { ::umount2(m.c_str(), MNT_DETACH); }
    } guard{m};
    const std::string ck = "run navier-stokes-2d --N 32 --fftw-estimate --dt 0.01 --checkpoint m/ck.h5 ";
    ASSERT_EQ(run_in(w, ck + "--steps 8 --checkpoint-every 8").status, 0);
    const std::string good = read_text(m / "ck.h5");
    ASSERT_GT(good.size(), 8000u);
    // fill the disk, then free a little: less than a checkpoint's size is left
    for (const std::size_t leave : {std::size_t(0), std::size_t(2048), std::size_t(4096)}) {  // < a checkpoint
        {
            std::ofstream fill(m / "fill", std::ios::binary);
            const std::string block(1024, 'x');
            while (fill.write(block.data(), block.size())) {
            }
        }
        if (leave) fs::resize_file(m / "fill", fs::file_size(m / "fill") > leave ? fs::file_size(m / "fill") - leave : 0);
        for (const std::string args : {"--steps 16 --checkpoint-every 8", "--steps 16 --checkpoint-every 8 --output m/o.csv",
                                       "--steps 2 --snapshot-every 1 --snapshot-dir m"}) {
            const run_result r = run_in(w, ck + args);
            EXPECT_EQ(r.status, 1) << leave << " " << args << ": " << r.err;
            EXPECT_EQ(lines_of(r.err).size(), 1u) << r.err;
            EXPECT_NE(r.err.find("cannot write"), std::string::npos) << r.err;
            EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << "the reason, named: " << r.err;
            EXPECT_TRUE(read_text(m / "ck.h5") == good) << "checkpoint changed: " << leave << " " << args;
            EXPECT_FALSE(fs::exists(m / "o.csv"));
            EXPECT_TRUE(temporaries(w.path()).empty()) << leave << " " << args;
        }
        fs::remove(m / "fill");
    }
}

// Every output a full disk can stop names the reason: the run is repeated with 0, 1, 2, ... pages (4 KiB) left on a
// small tmpfs, so that the checkpoint, a snapshot's HDF5 file, its spectrum, its picture, the CSV, the JSON and the
// FFTW wisdom each are the first write that fails in some run. Every failing run exits 1 with one line that names
// the file and "No space left on device", and leaves nothing behind; each kind of output is seen failing at least
// once. Skipped where tmpfs cannot be mounted.
TEST(CliSpectralOutputs, FullDiskFailuresNameTheReasonForEveryOutput) {
    work_dir w("spectral-full-reason");
    const fs::path m = w.file("m");
    fs::create_directory(m);
    if (::mount("tmpfs", m.c_str(), "tmpfs", 0, "size=256k") != 0) {
        GTEST_SKIP() << "cannot mount a tmpfs here (not root or not permitted): full-disk cases not run";
    }
    struct unmount {
        fs::path m;
        ~unmount() { ::umount2(m.c_str(), MNT_DETACH); }
    } guard{m};
    const bool pictures = std::system("gnuplot --version >/dev/null 2>&1") == 0;
    const auto fill_leaving = [&](std::size_t pages) {
        {
            std::ofstream fill(m / "fill", std::ios::binary);
            const std::string block(4096, 'x');
            while (fill.write(block.data(), block.size())) {
            }
        }
        const std::uintmax_t size = fs::file_size(m / "fill");
        fs::resize_file(m / "fill", size > pages * 4096 ? size - pages * 4096 : 0);
    };
    const std::string run = "run navier-stokes-2d --N 32 --fftw-estimate --dt 0.01 ";
    // (output as named in the message, the run that makes it fail)
    const std::vector<std::pair<std::string, std::string>> families{
        {"checkpoint", run + "--fftw-wisdom none --steps 8 --checkpoint-every 8 --checkpoint m/ck.h5"},
        {"snapshots", run + "--fftw-wisdom none --steps 1 --snapshot-every 1 --snapshot-dir m"},
        {"CSV and JSON", run + "--fftw-wisdom none --steps 40 --output m/o.csv --summary-json m/o.json"},
        {"wisdom", run + "--steps 1 --fftw-wisdom m/w"}};
    std::map<std::string, int> seen;  // kind of output named in a failure -> runs
    for (const auto& [family, args] : families) {
        bool succeeded = false;
        for (std::size_t pages = 0; pages < 60 && !succeeded; ++pages) {
            fill_leaving(pages);
            const run_result r = run_in(w, args);
            const std::string at = family + " with " + std::to_string(pages) + " pages: " + r.err;
            succeeded = r.status == 0;
            if (!succeeded) {
                EXPECT_EQ(r.status, 1) << at;
                EXPECT_EQ(lines_of(r.err).size(), 1u) << at;
                EXPECT_NE(r.err.find("cannot write"), std::string::npos) << at;
                EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << "the reason, named: " << at;
                for (const char* kind : {"checkpoint", "vorticity_", "spectrum_", ".png", "CSV output",
                                         "summary JSON", "wisdom"})
                    if (r.err.find(kind) != std::string::npos) ++seen[kind];
                // nothing committed, nothing left (the fill aside)
                for (const auto& e : fs::directory_iterator(m))
                    if (e.path().filename() != "fill") ADD_FAILURE() << at << " left " << e.path();
            }
            for (const auto& e : fs::directory_iterator(m))
                if (e.path().filename() != "fill") fs::remove_all(e.path());
            fs::remove(m / "fill");
        }
        EXPECT_TRUE(succeeded) << family << ": no run succeeded with up to 59 pages free (the control)";
    }
    for (const char* kind : {"checkpoint", "vorticity_", "spectrum_", ".png", "CSV output", "summary JSON", "wisdom"})
        if (pictures || std::string(kind) != ".png") {
            EXPECT_GT(seen[kind], 0) << "no run failed on writing " << kind;
        }
}

// Memory before the first step. Too many --output-dt times and an --ic file declaring a huge dataset
// are refused at once, in little memory (a 400 MB address-space limit: the old behaviour needed gigabytes).
TEST(CliSpectralOutputs, NoGigabytesBeforeTheFirstStep) {
    work_dir w("spectral-memory");
    const std::string limit = "ulimit -v 400000; ";
    for (const std::string args :
         {"run three-wave --method c-dp54 --rtol 1e-6 --output-dt 1e-3 --t-end 1e5",
          "run three-wave --method c-dp54 --rtol 1e-6 --output-dt 1e-5 --t-end 1e4 --output o.csv",
          "run kepler --method c-dp54 --rtol 1e-8 --output-dt 1e-4 --t-end 1e6"}) {
        const run_result r = w.run(args, limit);
        expect_refused(r, args);
        EXPECT_NE(r.err.find("10^7"), std::string::npos) << r.err;
        EXPECT_TRUE(w.files().empty()) << args;
    }
    // small files declaring big datasets (never written: HDF5 allocates nothing for them)
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    auto declare = [&](const std::string& name, const char* dataset, std::vector<hsize_t> dims, bool snapshot_format) {
        const hid_t f = H5Fcreate(w.file(name).c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
        const hid_t sp = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
        const hid_t d = H5Dcreate2(f, dataset, H5T_NATIVE_DOUBLE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
        if (snapshot_format) {
            const hid_t t = H5Tcopy(H5T_C_S1);
            const std::string v = "eci navier-stokes-2d snapshot";
            H5Tset_size(t, v.size());
            const hid_t s1 = H5Screate(H5S_SCALAR);
            const hid_t a = H5Acreate2(f, "format", t, s1, H5P_DEFAULT, H5P_DEFAULT);
            H5Awrite(a, t, v.data());
            H5Aclose(a), H5Sclose(s1), H5Tclose(t);
        }
        H5Dclose(d), H5Sclose(sp), H5Fclose(f);
        EXPECT_LT(fs::file_size(w.file(name)), 100000u) << name;
    };
    declare("big.h5", "vorticity", {12000, 12000}, true);
    declare("bigger.h5", "vorticity", {30000, 30000}, false);
    declare("oblong.h5", "vorticity", {16, 40000000}, true);
    for (const char* f : {"big.h5", "bigger.h5", "oblong.h5"}) {
        const run_result r = w.run(small + "--fftw-wisdom none --ic " + f + " --output o.csv", limit);
        expect_refused(r, f);
        EXPECT_NE(r.err.find("grid"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(w.file("o.csv")));
    }
}

}  // namespace

#endif  // ECI_CLI_PATH

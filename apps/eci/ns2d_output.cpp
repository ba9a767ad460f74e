// HDF5 snapshots and checkpoints of the spectral equations' `eci run` (C API; fixed-length string attributes,
// readable by h5py), and gnuplot figures of the field and of E(k). Every file is written under a temporary name, renamed.
#include "ns2d_output.hpp"

#include "command.hpp"
#include "h5_series.hpp"
#include "output.hpp"

#include <eci/steps.hpp>

#include <hdf5.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <variant>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

namespace eci::cli {

namespace {

// One HDF5 handle, closed by the matching function.
struct handle {
    hid_t id;
    herr_t (*close)(hid_t);
    handle(hid_t i, herr_t (*c)(hid_t), const std::string& what) : id(i), close(c) {
        if (id < 0) throw std::runtime_error(what);
    }
    ~handle() {
        if (id >= 0) close(id);
    }
    handle(const handle&) = delete;
    handle& operator=(const handle&) = delete;
    operator hid_t() const { return id; }
    /// Closes now and throws runtime_error(what) if that fails. A written dataset must be closed so: HDF5 keeps a
    /// small hyperslab write (a process's block of a file) in the dataset's sieve buffer and writes it to the file
    /// at H5Dclose, whose failure (EFBIG, ENOSPC) is reported there alone: the buffer is dropped, and the file's
    /// flush and close that follow succeed, the block missing (seen: rank 1's columns of a checkpoint, past a file
    /// size limit, lost without an error).
    void close_checked(const std::string& what) {
        const hid_t i = id;
        id = -1;
        if (close(i) < 0) throw std::runtime_error(what);
    }
};

hid_t untimed_file_properties();
hid_t any_attribute_size_access();

// The system error HDF5's file driver last reported, 0 if none. HDF5 puts it in its error stack's text ("..., errno
// = 28, error message = 'No space left on device', ..."), and clears that stack at the next call (a handle closed
// while the exception unwinds), so it is noted by the handler HDF5 calls at the failing function's return.
// Without one, the innermost description stands in for it.
int hdf5_errno = 0;
std::string hdf5_detail;

herr_t note_system_error(hid_t stack, void*) {
    H5Ewalk2(
        stack, H5E_WALK_DOWNWARD,
        [](unsigned, const H5E_error2_t* err, void*) -> herr_t {
            // (downward: from the API function to where the error arose, so the innermost one stays)
            if (!err || !err->desc) return 0;
            if (const char* at = std::strstr(err->desc, "errno = "))
                if (const int e = std::atoi(at + 8); e > 0) hdf5_errno = e;
            hdf5_detail.assign(err->desc, std::min<std::size_t>(std::strlen(err->desc), 200));
            return 0;
        },
        nullptr);
    return 0;
}

void quiet_hdf5() {
    static const bool done = [] {
        // No cleanup at exit: after a failed flush or close (a full disk) HDF5's own shutdown would flush the
        // half-closed file again and crash (exit 139 instead of 1); every file is closed here.
        H5dont_atexit();
        // Nothing printed: the errors become exceptions with one-line messages; their system reason is noted.
        return H5Eset_auto2(H5E_DEFAULT, note_system_error, nullptr) >= 0;
    }();
    (void)done;
}

// Starts an HDF5 write of `file`: HDF5 quiet, no reason noted yet. Returns what a failure's message ends with: the
// system's reason, else the file system's (a full disk whose driver error was not seen), else HDF5's.
auto begin_hdf5_write(const std::string& file) {
    quiet_hdf5();
    hdf5_errno = 0;
    hdf5_detail.clear();
    return [file] {
        return ": " + write_failure_reason(file, hdf5_errno,
                                           hdf5_detail.empty() ? "HDF5 gave no reason" : "HDF5: " + hdf5_detail);
    };
}

// Creates `file` as HDF5, fill(file id) writes it; the flush and the close are checked (a full disk shows up there, in
// HDF5's buffered writes), so a file that could not be written whole is an error, never a committed file. Every
// message ends with the reason: the system's, as HDF5's file driver reported it, or what the file system says.
// (create false: `file` is an HDF5 file another process created, opened to write into.)
template <class Fill>
void write_h5(const std::string& file, const std::string& what, Fill fill, bool create = true) {
    const auto why = begin_hdf5_write(file);
    const hid_t id = create ? H5Fcreate(file.c_str(), H5F_ACC_TRUNC, untimed_file_properties(),
                                        any_attribute_size_access())
                            : H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    if (id < 0)
        throw run_error("cannot write " + what + ": HDF5 could not " + (create ? "create" : "open") + " the file" +
                        why());
    try {
        fill(id);
    } catch (const std::exception& e) {
        const std::string reason = why();
        H5Fclose(id);
        throw run_error("cannot write " + what + ": " + e.what() + reason);
    }
    const bool flushed = H5Fflush(id, H5F_SCOPE_LOCAL) >= 0;
    const bool closed = H5Fclose(id) >= 0;
    if (!flushed || !closed)
        throw run_error("cannot write " + what + ": HDF5 could not " + (flushed ? "close" : "flush") + " the file" +
                        why());
}

template <class T>
hid_t native();
template <> hid_t native<double>() { return H5T_NATIVE_DOUBLE; }
template <> hid_t native<std::uint64_t>() { return H5T_NATIVE_UINT64; }
template <> hid_t native<std::int64_t>() { return H5T_NATIVE_INT64; }

template <class T>
void put(hid_t obj, const char* name, T v) {
    handle sp(H5Screate(H5S_SCALAR), H5Sclose, "HDF5 dataspace");
    handle a(H5Acreate2(obj, name, native<T>(), sp, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
             std::string("HDF5 attribute ") + name);
    if (H5Awrite(a, native<T>(), &v) < 0) throw std::runtime_error(std::string("HDF5 attribute ") + name);
}

void put(hid_t obj, const char* name, const std::string& v) {
    handle t(H5Tcopy(H5T_C_S1), H5Tclose, "HDF5 string type");
    H5Tset_size(t, std::max<std::size_t>(v.size(), 1));
    handle sp(H5Screate(H5S_SCALAR), H5Sclose, "HDF5 dataspace");
    handle a(H5Acreate2(obj, name, t, sp, H5P_DEFAULT, H5P_DEFAULT), H5Aclose, std::string("HDF5 attribute ") + name);
    const std::string data = v.empty() ? std::string(1, '\0') : v;
    if (H5Awrite(a, t, data.data()) < 0) throw std::runtime_error(std::string("HDF5 attribute ") + name);
}

// An attribute as T. HDF5 would convert any number to any other (a step of -5 written by hand became 0, a grid of
// 32.7 became 32): a whole number must be stored as an integer, a count (unsigned T) must not be negative, and a
// real must be stored as a number.
template <class T>
T get(hid_t obj, const char* name) {
    const auto bad = [&](const std::string& why) {
        return std::runtime_error(std::string("attribute '") + name + "' " + why);
    };
    if (H5Aexists(obj, name) <= 0) throw bad("missing");
    handle a(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, std::string("attribute ") + name);
    handle t(H5Aget_type(a), H5Tclose, "attribute type");
    const H5T_class_t kind = H5Tget_class(t);
    if constexpr (std::is_integral_v<T>) {
        if (kind != H5T_INTEGER) throw bad("is not a whole number");
        if (H5Tget_sign(t) == H5T_SGN_2) {
            std::int64_t v = 0;
            if (H5Aread(a, H5T_NATIVE_INT64, &v) < 0) throw bad("unreadable");
            if (std::is_unsigned_v<T> && v < 0) throw bad("is " + std::to_string(v) + ", not a count >= 0");
            return T(v);
        }
        std::uint64_t v = 0;
        if (H5Aread(a, H5T_NATIVE_UINT64, &v) < 0) throw bad("unreadable");
        if (std::is_signed_v<T> && v > std::uint64_t(std::numeric_limits<std::int64_t>::max()))
            throw bad("is " + std::to_string(v) + ", too large");
        return T(v);
    } else {
        if (kind != H5T_FLOAT && kind != H5T_INTEGER) throw bad("is not a number");
        T v{};
        if (H5Aread(a, native<T>(), &v) < 0) throw bad("unreadable");
        return v;
    }
}

// A string attribute, fixed-length (eci's own files) or variable-length (h5py's default for `attrs["x"] = "text"`,
// which a user's field file has), scalar or of one element.
std::string get_string(hid_t obj, const char* name) {
    if (H5Aexists(obj, name) <= 0) throw std::runtime_error(std::string("attribute '") + name + "' missing");
    handle a(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, std::string("attribute ") + name);
    handle t(H5Aget_type(a), H5Tclose, "attribute type");
    handle sp(H5Aget_space(a), H5Sclose, "attribute dataspace");
    if (H5Tget_class(t) != H5T_STRING || H5Sget_simple_extent_npoints(sp) != 1)
        throw std::runtime_error(std::string("attribute '") + name + "' is not a string");
    const auto unreadable = [&] { return std::runtime_error(std::string("attribute '") + name + "' unreadable"); };
    if (H5Tis_variable_str(t) > 0) {
        // read as a variable-length C string in memory (HDF5 allocates it; H5free_memory gives it back)
        handle mt(H5Tcopy(H5T_C_S1), H5Tclose, "HDF5 string type");
        if (H5Tset_size(mt, H5T_VARIABLE) < 0 || H5Tset_cset(mt, H5Tget_cset(t)) < 0) throw unreadable();
        char* text = nullptr;
        if (H5Aread(a, mt, &text) < 0) throw unreadable();
        std::string s = text ? std::string(text) : std::string();
        if (text) H5free_memory(text);
        return s;
    }
    std::string s(H5Tget_size(t), '\0');
    if (H5Aread(a, t, s.data()) < 0) throw unreadable();
    while (!s.empty() && s.back() == '\0') s.pop_back();
    return s;
}

/// File-creation properties whose root group carries no timestamps (kept for the process: one small object).
hid_t untimed_file_properties() {
    static const hid_t fcpl = [] {
        const hid_t p = H5Pcreate(H5P_FILE_CREATE);
        H5Pset_obj_track_times(p, false);
        return p;
    }();
    return fcpl;
}

// The files eci creates are in HDF5 1.8's format (readable by HDF5 1.8 and later, h5py's default since 2.x): its
// objects can hold attributes of any size. In the earliest format an attribute is at most 64 kB, and a checkpoint's
// fftw_wisdom attribute holds the process's FFTW wisdom, which grows with every size and thread count a wisdom file
// has planned: from ~64 kB of wisdom (five sizes, one and two threads) every checkpoint failed ("object header
// message is too large").
hid_t any_attribute_size_access() {
    static const hid_t fapl = [] {
        const hid_t p = H5Pcreate(H5P_FILE_ACCESS);
        H5Pset_libver_bounds(p, H5F_LIBVER_V18, H5F_LIBVER_V18);
        return p;
    }();
    return fapl;
}

void write_dataset(hid_t file, const char* name, const double* data, std::initializer_list<hsize_t> dims) {
    std::vector<hsize_t> d(dims);
    handle sp(H5Screate_simple(int(d.size()), d.data(), nullptr), H5Sclose, "HDF5 dataspace");
    // No object timestamps: two identical runs write identical files.
    handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "HDF5 dataset properties");
    H5Pset_obj_track_times(dcpl, false);
    handle ds(H5Dcreate2(file, name, H5T_NATIVE_DOUBLE, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT), H5Dclose,
              std::string("HDF5 dataset ") + name);
    if (H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
        throw std::runtime_error(std::string("HDF5 dataset ") + name);
    ds.close_checked(std::string("HDF5 dataset ") + name);
}

#ifdef ECI_MPI
// A block of a two-dimensional dataset of doubles: rows start[0] .. + count[0] - 1, columns start[1] ..
// + count[1] - 1, held row-major in `data` (one process's part of a file's dataset).
struct block {
    const char* name;
    hsize_t start[2], count[2];
    const double* data;
};

// Creates the two-dimensional dataset `name` (doubles, rows x columns) as write_dataset creates it, and writes zeros
// into all of it, a block of rows at a time (at most 1 MiB in memory): the file reaches its full size here, in the one
// process that creates it, so that a full disk or a file size limit fails here and not in the collective write of the
// blocks, which then only overwrites bytes the file already has. (Not H5D_ALLOC_TIME_EARLY: allocated at creation,
// the dataset would lie 328 bytes before where the serial writer's first write puts it; the first write of zeros
// allocates it there, the whole dataset at once, and the file keeps the serial layout byte for byte.)
void allocate_dataset(hid_t file, const char* name, hsize_t rows, hsize_t columns) {
    const hsize_t dims[2] = {rows, columns};
    handle sp(H5Screate_simple(2, dims, nullptr), H5Sclose, "HDF5 dataspace");
    handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "HDF5 dataset properties");
    H5Pset_obj_track_times(dcpl, false);
    handle ds(H5Dcreate2(file, name, H5T_NATIVE_DOUBLE, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT), H5Dclose,
              std::string("HDF5 dataset ") + name);
    const hsize_t per = std::max<hsize_t>(1, (hsize_t(1) << 17) / std::max<hsize_t>(columns, 1));
    const std::vector<double> zeros(std::size_t(std::min(per, rows) * columns), 0.0);
    for (hsize_t row = 0; row < rows; row += per) {
        const hsize_t start[2] = {row, 0}, count[2] = {std::min(per, rows - row), columns};
        handle fs(H5Dget_space(ds), H5Sclose, "HDF5 dataspace");
        handle ms(H5Screate_simple(2, count, nullptr), H5Sclose, "HDF5 dataspace");
        if (H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
            H5Dwrite(ds, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, zeros.data()) < 0)
            throw std::runtime_error(std::string("HDF5 dataset ") + name);
    }
    ds.close_checked(std::string("HDF5 dataset ") + name);  // (the last zeros, if they wait in the sieve buffer)
}
#endif

// Rows start[0] .. and columns start[1] .. (count[0] x count[1]) of a two-dimensional dataset whose shape has been
// checked, row-major.
std::vector<double> read_block(hid_t file, const char* name, const hsize_t (&start)[2], const hsize_t (&count)[2]) {
    std::vector<double> v(static_cast<std::size_t>(count[0]) * static_cast<std::size_t>(count[1]));
    if (v.empty()) return v;
    handle ds(H5Dopen2(file, name, H5P_DEFAULT), H5Dclose, std::string("dataset ") + name);
    handle fs(H5Dget_space(ds), H5Sclose, "dataspace");
    handle ms(H5Screate_simple(2, count, nullptr), H5Sclose, "dataspace");
    if (H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
        H5Dread(ds, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, v.data()) < 0)
        throw std::runtime_error(std::string("dataset '") + name + "' unreadable");
    return v;
}

// The dataset's shape is checked against `expected` (when given) before anything is allocated or read: a small
// file declaring a huge dataset is refused, not read. read false: the shape alone.
std::vector<double> read_dataset(hid_t file, const char* name, std::vector<hsize_t>& dims,
                                 const std::vector<hsize_t>& expected = {}, bool read = true) {
    if (H5Lexists(file, name, H5P_DEFAULT) <= 0) throw std::runtime_error(std::string("dataset '") + name + "' missing");
    handle ds(H5Dopen2(file, name, H5P_DEFAULT), H5Dclose, std::string("dataset ") + name);
    handle sp(H5Dget_space(ds), H5Sclose, "dataspace");
    const int rank = H5Sget_simple_extent_ndims(sp);
    if (rank < 1 || rank > 2) throw std::runtime_error(std::string("dataset '") + name + "' has the wrong rank");
    dims.assign(std::size_t(rank), 0);
    H5Sget_simple_extent_dims(sp, dims.data(), nullptr);
    if (!expected.empty() && dims != expected) {
        std::string shape;
        for (hsize_t d : dims) {  // appended, not operator+: GCC 12 warns falsely (-Wstringop-overflow) on that
            if (!shape.empty()) shape.push_back('x');
            shape.append(std::to_string(d));
        }
        throw std::runtime_error(std::string("dataset '") + name + "' is " + shape + ", not the grid's");
    }
    if (!read) return {};
    std::size_t count = 1;
    for (hsize_t d : dims) count *= std::size_t(d);
    std::vector<double> v(count);
    if (H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
        throw std::runtime_error(std::string("dataset '") + name + "' unreadable");
    return v;
}

void put_params(hid_t f, const ns2d_params& p) {
    put(f, "N", std::int64_t(p.n));
    put(f, "nu", p.nu);
    put(f, "hyper_nu", p.hyper_nu);
    put(f, "hyper_p", std::int64_t(p.hyper_p));
    put(f, "drag", p.drag);
    put(f, "forcing", std::string(ns2d_params::forcing_name(p.forcing)));
    put(f, "forcing_k", p.forcing_k);
    put(f, "forcing_amplitude", p.forcing_amplitude);
    put(f, "injection_rate", p.injection_rate);
    put(f, "forcing_seed", p.forcing_seed);
    put(f, "domain_length", 2.0 * M_PI);
    put(f, "equation", p.equation);
    put(f, "beta", p.beta);
    put(f, "deformation", p.deformation);
    put(f, "hypo_nu", p.hypo_nu);
    put(f, "hypo_p", std::int64_t(p.hypo_p));
    put(f, "fftw_measure", std::int64_t(p.measure ? 1 : 0));
    put(f, "pruned_transforms", std::int64_t(p.pruned_transforms ? 1 : 0));
}

// The format attribute of an equation's checkpoints and snapshots ("eci navier-stokes-2d checkpoint", ...).
std::string format_of(const std::string& equation, const char* kind) { return "eci " + equation + " " + kind; }

// The equation a checkpoint or snapshot's format names, or empty.
std::string equation_of_format(const std::string& format, const char* kind) {
    for (const spectral::equation* e : spectral::equations())
        if (format == format_of(std::string(e->name), kind)) return std::string(e->name);
    return {};
}

// The names of an equation's datasets: its field ("vorticity") and its state ("omega_hat").
std::string field_dataset(const spectral::equation& e) {
    std::string s(e.field);
    for (char& c : s)
        if (c == ' ') c = '_';
    return s;
}
std::string state_dataset(const spectral::equation& e) { return std::string(e.symbol) + "_hat"; }

handle open_for_reading(const std::string& path) {
    quiet_hdf5();
    if (const std::string why = unreadable_reason(path); !why.empty())
        throw std::runtime_error("cannot read " + path + ": " + why);
    if (H5Fis_hdf5(path.c_str()) <= 0) throw std::runtime_error(path + " is not an HDF5 file");
    return handle(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "cannot open " + path);
}

void put_checkpoint_attributes(hid_t f, const ns2d_checkpoint& c, std::uint64_t checksum) {
        put(f, "format", format_of(c.params.equation, "checkpoint"));
        put(f, "state_checksum", checksum);
        put(f, "version", std::int64_t(1));
        put_params(f, c.params);
        put(f, "threads", std::int64_t(c.params.threads));
        put(f, "method", c.method);
        put(f, "update", c.update);
        put(f, "dt", c.dt);
        put(f, "step", c.step);
        put(f, "time", double(c.step) * c.dt);
        put(f, "total_steps", c.total_steps);
        put(f, "t_end", c.t_end);
        put(f, "rng_state", c.rng_state);
        put(f, "fftw_wisdom", c.keep_wisdom ? navier_stokes_2d::fftw_wisdom() : std::string());
        put(f, "halvings", c.halvings);
        put(f, "rhs_evals", c.rhs_evals);
        put(f, "energy_injection", c.budget.energy_injection);
        put(f, "energy_dissipation", c.budget.energy_dissipation);
        put(f, "enstrophy_injection", c.budget.enstrophy_injection);
        put(f, "enstrophy_dissipation", c.budget.enstrophy_dissipation);
        put(f, "energy0", c.energy0);
        put(f, "enstrophy0", c.enstrophy0);
        put(f, "max_energy_drift", c.max_energy_drift);
        put(f, "max_enstrophy_drift", c.max_enstrophy_drift);
        put(f, "max_energy_residual", c.max_energy_residual);
        put(f, "max_enstrophy_residual", c.max_enstrophy_residual);
}

void put_snapshot_attributes(hid_t f, const navier_stokes_2d& m, double t, std::uint64_t step,
                             const std::string& method, double dt) {
        put(f, "format", format_of(m.params().equation, "snapshot"));
        put(f, "field", field_dataset(m.eq()));
        put_params(f, m.params());
        put(f, "time", t);
        put(f, "step", step);
        put(f, "method", method);
        put(f, "dt", dt);
}

// The grid's coordinates x_i = 2 pi i / n (a snapshot's x and y).
std::vector<double> coordinates(int n) {
    std::vector<double> x(std::size_t(n), 0.0);
    for (int i = 0; i < n; ++i) x[std::size_t(i)] = 2.0 * M_PI * i / n;
    return x;
}

#ifdef ECI_MPI
// The second part of an MPI run's file: rank 0 has created `file` (rank 0's name for it) with every attribute and
// every dataset at its full size (allocate_dataset; its own failure's reason in root_failure, empty if none); now
// every process of comm opens it at once with parallel HDF5 (the MPI-IO file driver) and writes `part` of its dataset
// in one collective write (H5FD_MPIO_COLLECTIVE), then all close it. Nothing in this part changes the file's
// metadata or size: a full disk was met by rank 0 alone, before. What could still fail here is found first, on each
// process, and agreed before the collective part: a write past the process's file size limit (RLIMIT_FSIZE) fails
// wherever in the file it falls, even on bytes the file has. (Left to the collective write, that failure ended every
// process without a hang, but MPI-IO reports it as a short write, so the reason was lost: "HDF5: file write failed";
// and had MPI-IO returned an error instead, HDF5 1.10.8 would skip the collective reset of the file view that
// follows the write, on the failing process alone.) sync: each process syncs the file after (a checkpoint's).
// what_given: what the messages name (empty: the snapshot `file`). Collective; returns, on every process, the reason
// of the lowest-ranked process that failed (empty: none did), ending with the system's reason as write_h5's
// messages do.
std::string write_collectively(MPI_Comm comm, const std::string& file, const std::string& root_failure,
                               const std::string& what_given, const block& part, bool sync) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    // the name and size of the file rank 0 created, or nothing if it could not
    std::string name = rank == 0 && root_failure.empty() ? file : std::string();
    unsigned long long head[2] = {name.size(), 0};
    if (rank == 0 && !name.empty()) {
        struct stat st {};
        if (::stat(name.c_str(), &st) == 0) head[1] = static_cast<unsigned long long>(st.st_size);
    }
    MPI_Bcast(head, 2, MPI_UNSIGNED_LONG_LONG, 0, comm);
    if (head[0] == 0) return first_failure(comm, rank == 0 ? root_failure : std::string());
    name.resize(std::size_t(head[0]));
    MPI_Bcast(name.data(), int(head[0]), MPI_CHAR, 0, comm);
    const std::string what = what_given.empty() ? "snapshot '" + name + "'" : what_given;
    // Before anything collective: this process may write anywhere in the file (MPI-IO's collective buffering lets
    // any process write any other's bytes), so the whole file must lie within its file size limit.
    std::string mine;
    if (struct rlimit fsize {}; ::getrlimit(RLIMIT_FSIZE, &fsize) == 0 && fsize.rlim_cur != RLIM_INFINITY &&
                                static_cast<unsigned long long>(fsize.rlim_cur) < head[1])
        mine = "cannot write " + what + ": the file's " + std::to_string(head[1]) +
               " bytes are beyond this process's file size limit of " + std::to_string(fsize.rlim_cur) + ": " +
               write_failure_reason(name, EFBIG);
    if (std::string first = first_failure(comm, mine); !first.empty()) return first;

    const auto why = begin_hdf5_write(name);
    const hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    H5Pset_fapl_mpio(fapl, comm, MPI_INFO_NULL);
    const hid_t id = H5Fopen(name.c_str(), H5F_ACC_RDWR, fapl);
    H5Pclose(fapl);
    // The open is collective (MPI_File_open): it fails on every process or on none; agreed before anything else.
    // Should it have failed on some alone, the others leave their file open (closing is collective: they would wait
    // for the processes that have no file to close); the run ends with the failure.
    int opened = id >= 0 ? 1 : 0, all_opened = 0;
    MPI_Allreduce(&opened, &all_opened, 1, MPI_INT, MPI_MIN, comm);
    if (!all_opened)
        return first_failure(comm,
                             opened ? std::string() : "cannot write " + what + ": HDF5 could not open the file" + why());
    // Every process makes the same HDF5 calls in the same order, whatever failed on it; a failure is noted, not
    // thrown, until the file is closed.
    const auto note = [&](const std::string& failure) {
        if (mine.empty()) mine = "cannot write " + what + ": " + failure + why();
    };
    const std::string dataset = std::string("HDF5 dataset ") + part.name;
    if (const hid_t ds = H5Dopen2(id, part.name, H5P_DEFAULT); ds < 0) {  // (metadata: the same on every process)
        note(dataset);
    } else {
        const hid_t fs = H5Dget_space(ds);
        const bool empty = part.count[0] == 0 || part.count[1] == 0;
        const hsize_t one[2] = {1, 1};
        const hid_t ms = H5Screate_simple(2, empty ? one : part.count, nullptr);
        if (empty) {  // (no rows or columns: the process takes part in the write with nothing)
            H5Sselect_none(fs);
            H5Sselect_none(ms);
        } else if (H5Sselect_hyperslab(fs, H5S_SELECT_SET, part.start, nullptr, part.count, nullptr) < 0) {
            note(dataset + ": block outside the dataset");
            H5Sselect_none(fs);
            H5Sselect_none(ms);
        }
        const hid_t dxpl = H5Pcreate(H5P_DATASET_XFER);
        H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE);
        const double none = 0.0;
        if (H5Dwrite(ds, H5T_NATIVE_DOUBLE, ms, fs, dxpl, empty ? &none : part.data) < 0) note(dataset);
        H5Pclose(dxpl);
        H5Sclose(ms);
        H5Sclose(fs);
        if (H5Dclose(ds) < 0) note(dataset);
    }
    if (H5Fclose(id) < 0) note("HDF5 could not close the file");
    if (mine.empty() && sync) {
        try {
            sync_file(name, what);  // (this process's writes, wherever it runs)
        } catch (const std::exception& e) {
            mine = e.what();
        }
    }
    return first_failure(comm, mine);
}

// Rank 0's text on every process (collective).
std::string from_root(MPI_Comm comm, std::string text) {
    unsigned long long length = text.size();
    MPI_Bcast(&length, 1, MPI_UNSIGNED_LONG_LONG, 0, comm);
    text.resize(std::size_t(length));
    MPI_Bcast(text.data(), int(length), MPI_CHAR, 0, comm);
    return text;
}
#endif

}  // namespace

#ifdef ECI_MPI
std::string first_failure(MPI_Comm comm, const std::string& mine) {
    int rank = 0, size = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &size);
    int me = mine.empty() ? size : rank, first = size;
    MPI_Allreduce(&me, &first, 1, MPI_INT, MPI_MIN, comm);
    if (first == size) return {};
    std::string text = rank == first ? mine : std::string();
    unsigned long long length = text.size();
    MPI_Bcast(&length, 1, MPI_UNSIGNED_LONG_LONG, first, comm);
    text.resize(std::size_t(length));
    MPI_Bcast(text.data(), int(length), MPI_CHAR, first, comm);
    return text;
}
#endif

std::uint64_t state_checksum(const std::complex<double>* state, int n, int first_column, int columns) {
    const std::uint64_t width = std::uint64_t(n / 2 + 1);
    const auto mix = [](std::uint64_t z) {  // splitmix64's finaliser
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    };
    std::uint64_t sum = 0;
    for (std::uint64_t y = 0; y < std::uint64_t(n); ++y)
        for (std::uint64_t j = 0; j < std::uint64_t(columns); ++j) {
            const std::complex<double>& v = state[y * std::uint64_t(columns) + j];
            const std::uint64_t g = y * width + std::uint64_t(first_column) + j;
            std::uint64_t re = 0, im = 0;
            std::memcpy(&re, &reinterpret_cast<const double(&)[2]>(v)[0], sizeof re);
            std::memcpy(&im, &reinterpret_cast<const double(&)[2]>(v)[1], sizeof im);
            sum += mix(mix(2 * g + 0x9E3779B97F4A7C15ull) ^ re) + mix(mix(2 * g + 1 + 0x9E3779B97F4A7C15ull) ^ im);
        }
    return sum;
}

std::string checksum_mismatch(const std::string& path, const std::string& equation) {
    return path + ": " + state_dataset(spectral::find_equation(equation)) +
           " does not match its checksum (a damaged or edited file)";
}

void write_checkpoint(const std::string& path, const ns2d_checkpoint& c) {
    const std::uint64_t checksum = state_checksum(c.state.data(), c.params.n, 0, c.params.n / 2 + 1);
    write_replacing(path, "checkpoint", [&](const std::string& tmp) {
        write_h5(tmp, "checkpoint '" + path + "'", [&](hid_t f) {
        put_checkpoint_attributes(f, c, checksum);
        const hsize_t rows = hsize_t(c.params.n), cols = hsize_t(c.params.n / 2 + 1);
        write_dataset(f, state_dataset(spectral::find_equation(c.params.equation)).c_str(),
                      reinterpret_cast<const double*>(c.state.data()), {rows, cols * 2});
        });
    });
}

#ifdef ECI_MPI
void write_checkpoint(const std::string& path, const ns2d_checkpoint& c, MPI_Comm comm, int first_column,
                      int columns) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    const std::string what = "checkpoint '" + path + "'";
    const std::string name = state_dataset(spectral::find_equation(c.params.equation));
    const hsize_t rows = hsize_t(c.params.n), cols = hsize_t(c.params.n / 2 + 1);
    const block mine{name.c_str(), {0, 2 * hsize_t(first_column)}, {rows, 2 * hsize_t(columns)},
                     reinterpret_cast<const double*>(c.state.data())};
    if (c.state.size() != std::size_t(rows) * std::size_t(columns))
        throw std::logic_error("write_checkpoint: the state is not n rows of this process's columns");
    // the whole state's checksum: every process's part, summed (collective, before rank 0 writes the attributes)
    const std::uint64_t part = state_checksum(c.state.data(), c.params.n, first_column, columns);
    std::uint64_t checksum = 0;
    MPI_Allreduce(&part, &checksum, 1, MPI_UINT64_T, MPI_SUM, comm);
    std::string failure;
    if (rank == 0) {
        // the temporary: its attributes and the whole dataset, allocated (rank 0 alone); then every process's
        // columns, written collectively; then (rank 0) synced and renamed over the checkpoint
        bool created = false;
        try {
            write_replacing(path, "checkpoint", [&](const std::string& tmp) {
                std::string own;
                try {
                    write_h5(tmp, what, [&](hid_t f) {
                        put_checkpoint_attributes(f, c, checksum);
                        allocate_dataset(f, name.c_str(), rows, cols * 2);
                    });
                } catch (const std::exception& e) {
                    own = e.what();
                }
                created = true;
                if (const std::string first = write_collectively(comm, tmp, own, what, mine, true); !first.empty())
                    throw run_error(first);
            });
        } catch (const std::exception& e) {
            if (!created) write_collectively(comm, {}, e.what(), what, mine, true);  // (the others wait for a name)
            failure = e.what();
        }
    } else {
        write_collectively(comm, {}, {}, what, mine, true);
    }
    // rank 0's verdict, the commit's included: the same on every process
    if (failure = from_root(comm, failure); !failure.empty()) throw run_error(failure);
}
#endif

ns2d_checkpoint read_checkpoint(const std::string& path, int n, bool with_state) {
    handle f = open_for_reading(path);
    const std::string equation =
        H5Aexists(f, "format") > 0 ? equation_of_format(get_string(f, "format"), "checkpoint") : std::string();
    if (equation.empty()) throw std::runtime_error(path + " is not an eci checkpoint");
    if (get<std::int64_t>(f, "version") != 1) throw std::runtime_error(path + ": unknown checkpoint version");
    ns2d_checkpoint c;
    ns2d_params& p = c.params;
    p.equation = equation;
    // Whole numbers are checked before they are narrowed: N = 2^32 + 16 is not 16.
    auto whole = [&](const char* name, std::int64_t lo, std::int64_t hi) {
        const std::int64_t v = get<std::int64_t>(f, name);
        if (v < lo || v > hi)
            throw std::runtime_error(path + ": " + name + " = " + std::to_string(v) + " is not in " +
                                     std::to_string(lo) + ".." + std::to_string(hi));
        return int(v);
    };
    // written since the spectral core; Navier-Stokes checkpoints written by older versions have none of them
    if (H5Aexists(f, "beta") > 0) p.beta = get<double>(f, "beta");
    if (H5Aexists(f, "deformation") > 0) p.deformation = get<double>(f, "deformation");
    if (H5Aexists(f, "hypo_nu") > 0) p.hypo_nu = get<double>(f, "hypo_nu");
    if (H5Aexists(f, "hypo_p") > 0) p.hypo_p = whole("hypo_p", 1, 16);
    // how the run planned its transforms (older checkpoints lack it: always FFTW_MEASURE unless --fftw-estimate)
    if (H5Aexists(f, "fftw_measure") > 0) p.measure = whole("fftw_measure", 0, 1) == 1;
    // which transforms (older checkpoints lack it: FFTW's 2-D plans, the only ones a run took then)
    p.pruned_transforms = H5Aexists(f, "pruned_transforms") > 0 && whole("pruned_transforms", 0, 1) == 1;
    p.n = whole("N", 8, 65536);
    if (n > 0 && p.n != n)  // before the state is read: it may be gigabytes
        throw std::runtime_error(path + " holds a " + std::to_string(p.n) + "^2 grid, not N = " + std::to_string(n));
    p.nu = get<double>(f, "nu");
    p.hyper_nu = get<double>(f, "hyper_nu");
    p.hyper_p = whole("hyper_p", 1, 16);
    p.drag = get<double>(f, "drag");
    const std::string forcing = get_string(f, "forcing");
    try {
        p.forcing = ns2d_params::forcing_named(forcing, [](std::string_view) { return std::string("forcing"); });
    } catch (const std::invalid_argument&) {
        throw std::runtime_error(path + ": unknown forcing '" + forcing + "'");
    }
    p.forcing_k = get<double>(f, "forcing_k");
    p.forcing_amplitude = get<double>(f, "forcing_amplitude");
    p.injection_rate = get<double>(f, "injection_rate");
    p.forcing_seed = get<std::uint64_t>(f, "forcing_seed");
    p.threads = whole("threads", 1, 64);
    p.wisdom = get_string(f, "fftw_wisdom");
    c.method = get_string(f, "method");
    if (H5Aexists(f, "update") > 0) {  // (absent from earlier versions' checkpoints: the default, conditioned)
        c.update = get_string(f, "update");
        if (c.update != "conditioned" && c.update != "paper")
            throw std::runtime_error(path + ": unknown update '" + c.update + "' (conditioned or paper)");
    }
    c.dt = get<double>(f, "dt");
    c.step = get<std::uint64_t>(f, "step");
    c.total_steps = get<std::uint64_t>(f, "total_steps");
    // (absent from the checkpoints of earlier versions, which ran whole steps to total_steps)
    c.t_end = H5Aexists(f, "t_end") > 0 ? get<double>(f, "t_end") : std::numeric_limits<double>::quiet_NaN();
    c.rng_state = get<std::uint64_t>(f, "rng_state");
    c.halvings = get<std::uint64_t>(f, "halvings");
    c.rhs_evals = get<std::uint64_t>(f, "rhs_evals");
    // (checkpoints of earlier versions have no checksum: they restart unchecked)
    if (H5Aexists(f, "state_checksum") > 0) c.checksum = get<std::uint64_t>(f, "state_checksum");
    c.budget.energy_injection = get<double>(f, "energy_injection");
    c.budget.energy_dissipation = get<double>(f, "energy_dissipation");
    c.budget.enstrophy_injection = get<double>(f, "enstrophy_injection");
    c.budget.enstrophy_dissipation = get<double>(f, "enstrophy_dissipation");
    c.energy0 = get<double>(f, "energy0");
    c.enstrophy0 = get<double>(f, "enstrophy0");
    c.max_energy_drift = get<double>(f, "max_energy_drift");
    c.max_enstrophy_drift = get<double>(f, "max_enstrophy_drift");
    c.max_energy_residual = get<double>(f, "max_energy_residual");
    c.max_enstrophy_residual = get<double>(f, "max_enstrophy_residual");
    // The numbers a continued run computes with: a frozen or backward clock, or a non-finite budget, is a corrupt
    // file, not a run.
    if (!(std::isfinite(c.dt) && c.dt > 0.0)) throw std::runtime_error(path + ": dt must be a positive number");
    if (c.step > c.total_steps) throw std::runtime_error(path + ": step is beyond total_steps");
    if (c.total_steps > max_grid_steps)
        throw std::runtime_error(path + ": total_steps " + std::to_string(c.total_steps) + " is beyond 2^53");
    // the time the file states is the step's on the grid, step * dt, as written
    if (H5Aexists(f, "time") > 0) {
        const double time = get<double>(f, "time");
        if (!(time == double(c.step) * c.dt))
            throw std::runtime_error(path + ": time " + eci::shortest_text(time) + " is not step * dt = " +
                                     std::to_string(c.step) + " * " + eci::shortest_text(c.dt));
    }
    // counts of the steps taken: every step takes at least one evaluation, and each halving is a step taken again
    if (c.rhs_evals < c.step)
        throw std::runtime_error(path + ": rhs_evals " + std::to_string(c.rhs_evals) + " is fewer than the " +
                                 std::to_string(c.step) + " steps taken");
    if (!std::isnan(c.t_end) && !(std::isfinite(c.t_end) && c.t_end >= 0.0 &&
                                  steps_to_reach(0.0, c.t_end, c.dt) == c.total_steps))
        throw std::runtime_error(path + ": t_end does not end total_steps steps of dt");
    for (const auto& [name, v] : {std::pair<const char*, double>{"energy0", c.energy0},
                                  {"enstrophy0", c.enstrophy0},
                                  {"energy_injection", c.budget.energy_injection},
                                  {"energy_dissipation", c.budget.energy_dissipation},
                                  {"enstrophy_injection", c.budget.enstrophy_injection},
                                  {"enstrophy_dissipation", c.budget.enstrophy_dissipation},
                                  {"max_energy_drift", c.max_energy_drift},
                                  {"max_enstrophy_drift", c.max_enstrophy_drift},
                                  {"max_energy_residual", c.max_energy_residual},
                                  {"max_enstrophy_residual", c.max_enstrophy_residual}})
        if (!std::isfinite(v)) throw std::runtime_error(path + ": " + name + " is not finite");
    // sums of squares and largest deviations, never negative
    for (const auto& [name, v] : {std::pair<const char*, double>{"energy0", c.energy0},
                                  {"enstrophy0", c.enstrophy0},
                                  {"max_energy_drift", c.max_energy_drift},
                                  {"max_enstrophy_drift", c.max_enstrophy_drift},
                                  {"max_energy_residual", c.max_energy_residual},
                                  {"max_enstrophy_residual", c.max_enstrophy_residual}})
        if (!(v >= 0.0)) throw std::runtime_error(path + ": " + name + " " + eci::shortest_text(v) + " is negative");
    std::vector<hsize_t> dims;
    const std::string name = state_dataset(spectral::find_equation(equation));
    const std::vector<double> v =
        read_dataset(f, name.c_str(), dims, {hsize_t(p.n), hsize_t(2 * (p.n / 2 + 1))}, with_state);
    if (!with_state) return c;
    if (dims.size() != 2 || dims[0] != hsize_t(p.n) || dims[1] != hsize_t(2 * (p.n / 2 + 1)))
        throw std::runtime_error(path + ": " + name + " does not match the grid N = " + std::to_string(p.n));
    c.state.resize(v.size() / 2);
    for (std::size_t i = 0; i < c.state.size(); ++i) {
        if (!std::isfinite(v[2 * i]) || !std::isfinite(v[2 * i + 1]))
            throw std::runtime_error(path + ": " + name + " holds a non-finite value");
        c.state[i] = {v[2 * i], v[2 * i + 1]};
    }
    if (c.checksum && state_checksum(c.state.data(), p.n, 0, p.n / 2 + 1) != *c.checksum)
        throw std::runtime_error(checksum_mismatch(path, equation));
    return c;
}

std::vector<std::complex<double>> read_checkpoint_columns(const std::string& path, const ns2d_checkpoint& header,
                                                          int first_column, int columns) {
    handle f = open_for_reading(path);
    const int n = header.params.n;
    const std::string name = state_dataset(spectral::find_equation(header.params.equation));
    std::vector<hsize_t> dims;
    read_dataset(f, name.c_str(), dims, {hsize_t(n), hsize_t(2 * (n / 2 + 1))}, false);  // (the shape again)
    if (first_column < 0 || columns < 0 || first_column + columns > n / 2 + 1)
        throw std::logic_error("read_checkpoint_columns: columns outside the half plane");
    const std::vector<double> v =
        read_block(f, name.c_str(), {0, 2 * hsize_t(first_column)}, {hsize_t(n), 2 * hsize_t(columns)});
    std::vector<std::complex<double>> state(v.size() / 2);
    for (std::size_t i = 0; i < state.size(); ++i) {
        if (!std::isfinite(v[2 * i]) || !std::isfinite(v[2 * i + 1]))
            throw std::runtime_error(path + ": " + name + " holds a non-finite value");
        state[i] = {v[2 * i], v[2 * i + 1]};
    }
    return state;
}

void write_snapshot_h5(const std::string& path, const navier_stokes_2d& m, const std::vector<double>& field,
                       double t, std::uint64_t step, const std::string& method, double dt) {
    write_h5(path, "snapshot '" + path + "'", [&](hid_t f) {
        put_snapshot_attributes(f, m, t, step, method, dt);
        const hsize_t n = hsize_t(m.n());
        write_dataset(f, field_dataset(m.eq()).c_str(), field.data(), {n, n});
        const std::vector<double> x = coordinates(m.n());
        write_dataset(f, "x", x.data(), {n});
        write_dataset(f, "y", x.data(), {n});
    });
}

#ifdef ECI_MPI
void write_snapshot_h5(const std::string& path, const navier_stokes_2d& m, const std::vector<double>& rows,
                       double t, std::uint64_t step, const std::string& method, double dt, MPI_Comm comm) {
    const spectral::grid& g = m.grid();
    const hsize_t n = hsize_t(m.n());
    const std::string name = field_dataset(m.eq());
    if (rows.size() != std::size_t(g.local_rows()) * std::size_t(n))
        throw std::logic_error("write_snapshot_h5: the field is not this process's rows");
    const block mine{name.c_str(), {hsize_t(g.first_row()), 0}, {hsize_t(g.local_rows()), n}, rows.data()};
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    // rank 0 creates the file as the serial writer writes it (attributes, the field, x, y), the field allocated
    // whole; then every process writes its rows of the field collectively
    const std::string what = "snapshot '" + path + "'";
    std::string own;
    if (rank == 0) {
        try {
            write_h5(path, what, [&](hid_t f) {
                put_snapshot_attributes(f, m, t, step, method, dt);
                allocate_dataset(f, name.c_str(), n, n);
                const std::vector<double> x = coordinates(m.n());
                write_dataset(f, "x", x.data(), {n});
                write_dataset(f, "y", x.data(), {n});
            });
        } catch (const std::exception& e) {
            own = e.what();
        }
    }
    const std::string first = write_collectively(comm, path, own, {}, mine, false);  // (named by rank 0's path)
    if (!first.empty()) throw run_error(first);
}
#endif

bool is_checkpoint(const std::string& path) {
    handle f = open_for_reading(path);
    return H5Aexists(f, "format") > 0 && !equation_of_format(get_string(f, "format"), "checkpoint").empty();
}

namespace {

// The name of a snapshot's field dataset and its grid size n, the shape checked (square, n when n > 0).
std::pair<std::string, int> snapshot_field(hid_t f, const std::string& path, int n, const std::string& own_field) {
    // The field the file's attribute `field` names (an eci snapshot's, of any equation); in a file without one (a
    // user's own field, a Navier-Stokes snapshot of before the spectral core) the run's own field ("buoyancy" for
    // surface-qg), else "vorticity", which every equation took before.
    std::string name;
    if (H5Aexists(f, "field") > 0) {
        name = get_string(f, "field");
        if (H5Lexists(f, name.c_str(), H5P_DEFAULT) <= 0)
            throw std::runtime_error("dataset '" + name + "' (named by its attribute 'field') missing");
    } else {
        for (const std::string& candidate : {own_field, std::string("vorticity")})
            if (!candidate.empty() && H5Lexists(f, candidate.c_str(), H5P_DEFAULT) > 0) {
                name = candidate;
                break;
            }
        if (name.empty())
            throw std::runtime_error(own_field.empty() || own_field == "vorticity"
                                         ? std::string("dataset 'vorticity' missing")
                                         : "dataset '" + own_field + "' (or 'vorticity') missing");
    }
    // the shape first: a file of another grid is refused before its field is read
    {
        handle ds(H5Dopen2(f, name.c_str(), H5P_DEFAULT), H5Dclose, "dataset " + name);
        handle sp(H5Dget_space(ds), H5Sclose, "dataspace");
        handle type(H5Dget_type(ds), H5Tclose, "dataset type");
        if (const H5T_class_t kind = H5Tget_class(type); kind != H5T_FLOAT && kind != H5T_INTEGER)
            throw std::runtime_error("dataset '" + name + "' does not hold real numbers");
        const int rank = H5Sget_simple_extent_ndims(sp);
        hsize_t d[2] = {0, 0};
        if (rank != 2 || H5Sget_simple_extent_dims(sp, d, nullptr) < 0 || d[0] != d[1]) {
            std::string shape = rank == 2 ? std::to_string(d[0]) + "x" + std::to_string(d[1])
                                          : "of " + std::to_string(std::max(rank, 0)) + " dimensions";
            throw std::runtime_error(path + ": " + name + " is " + shape + ", not a square grid");
        }
        if (n > 0 && d[0] != hsize_t(n))
            throw std::runtime_error(path + " holds a " + std::to_string(d[0]) + "^2 grid, not N = " +
                                     std::to_string(n));
        if (d[0] > hsize_t(1) << 30)  // (beyond any grid: the grid's own check says so for what an int holds)
            throw std::runtime_error(path + " holds a " + std::to_string(d[0]) + "^2 grid, beyond any N");
        return {name, int(d[0])};
    }
}

}  // namespace

std::pair<int, std::vector<double>> read_vorticity(const std::string& path, int n, bool with_field,
                                                   const std::string& own_field) {
    handle f = open_for_reading(path);
    const auto [name, size] = snapshot_field(f, path, n, own_field);
    if (!with_field) return {size, {}};
    std::vector<hsize_t> dims;
    std::vector<double> v = read_dataset(f, name.c_str(), dims);
    if (dims.size() != 2 || dims[0] != dims[1]) throw std::runtime_error(path + ": " + name + " is not a square grid");
    return {int(dims[0]), std::move(v)};
}

std::vector<double> read_vorticity_rows(const std::string& path, int n, int first_row, int rows,
                                        const std::string& own_field) {
    handle f = open_for_reading(path);
    const auto [name, size] = snapshot_field(f, path, n, own_field);
    if (first_row < 0 || rows < 0 || first_row + rows > size)
        throw std::logic_error("read_vorticity_rows: rows outside the grid");
    return read_block(f, name.c_str(), {hsize_t(first_row), 0}, {hsize_t(rows), hsize_t(size)});
}

bool plot_vorticity_png(const std::string& path, int n, const std::vector<double>& field, double t,
                        const std::string& name, const std::string& symbol) {
    const scoped_temporary data_file(path + ".bin");
    const std::string& tmp = path;
    char title[64];
    std::snprintf(title, sizeof title, "%s, t = %.4g", name.c_str(), t);
    std::string s = "set terminal pngcairo size 760,640\nset output " + gnuplot_quoted(tmp) + "\n";
    s += "set title " + gnuplot_quoted(title) + "\nset size ratio -1\n";
    s += field_image(data_file.path(), n, field, symbol);
    if (!draw_picture(s, tmp)) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        return false;
    }
    return true;
}

namespace {

// The picture of a spectrum CSV `csv_path` (write_spectrum's columns k, E, Z, Pi_E, Pi_Z), drawn to `png_path`: E(k)
// (e[k], k >= 1) log-log above, and below the fluxes Pi_E(k) and Pi_Z(k) through each shell (Pi_E on the left axis,
// Pi_Z on the right: the cascades' directions, positive to smaller scales); false if it was not drawn (no plotting
// program, or stopped).
bool draw_spectrum(const std::string& csv_path, const std::string& png_path, const std::vector<double>& e, double t) {
    // Guides through the spectrum's peak: k^-3 (enstrophy cascade) and k^-5/3 (inverse energy cascade).
    std::size_t kp = 1;
    for (std::size_t k = 1; k < e.size(); ++k)
        if (e[k] > e[kp]) kp = k;
    const double ep = std::max(e[kp], 1e-300);
    char title[64];
    std::snprintf(title, sizeof title, "energy spectrum, t = %.4g", t);
    const std::string& ptmp = png_path;
    const std::string csv = gnuplot_quoted(csv_path);
    std::string s = "set terminal pngcairo size 720,860\nset output " + gnuplot_quoted(ptmp) +
                    "\nset datafile separator ','\nset multiplot layout 2,1\nset autoscale xfix\n";
    s += "set logscale xy\nset format y '10^{%L}'\nset xlabel 'k'\nset ylabel 'E(k)'\nset key bottom left\n";
    s += "set title " + gnuplot_quoted(title) + "\n";
    s += "set yrange [" + gnuplot_number(ep * 1e-12) + ":" + gnuplot_number(ep * 10) + "]\n";
    s += "plot " + csv + " skip 1 using 1:($2 > 0 ? $2 : NaN) with linespoints pt 7 ps 0.4 title 'E(k)', ";
    s += gnuplot_number(ep) + "*(x/" + std::to_string(kp) + ".)**-3 with lines dt 2 lc rgb 'gray30' title 'k^{-3}', ";
    s += gnuplot_number(ep) + "*(x/" + std::to_string(kp) + ".)**(-5./3) with lines dt 3 lc rgb 'gray50' title 'k^{-5/3}'\n";
    // the fluxes: linear in Pi, log in k; a line at zero (above it the transfer is to larger k)
    s += "unset logscale y\nset logscale x\nset format y '%g'\nset format y2 '%g'\nset yrange [*:*]\nset y2range [*:*]\n";
    s += "set title 'fluxes through shell k (> 0: towards larger k)'\nset ylabel '{/Symbol P}_E(k)'\n";
    s += "set y2label '{/Symbol P}_Z(k)'\nset ytics nomirror\nset y2tics\nset key below\n";
    s += "plot " + csv + " skip 1 using 1:4 axes x1y1 with linespoints pt 7 ps 0.4 title '{/Symbol P}_E(k), left', ";
    s += csv + " skip 1 using 1:5 axes x1y2 with linespoints pt 5 ps 0.4 title '{/Symbol P}_Z(k), right', ";
    s += "0 axes x1y1 with lines lc rgb 'gray60' notitle\nunset multiplot\n";
    if (!draw_picture(s, ptmp)) {
        std::error_code ec;
        std::filesystem::remove(ptmp, ec);
        return false;
    }
    return true;
}

}  // namespace

void write_spectrum(const std::string& csv_path, const std::string& png_path, const spectrum_rows& r, double t) {
    const std::vector<double>& e = r.energy;
    write_new_file(csv_path, "spectrum", [&](std::FILE* f) {
        std::fprintf(f, "k,E,Z,Pi_E,Pi_Z\n");
        for (std::size_t k = 1; k < e.size(); ++k)
            std::fprintf(f, "%zu,%.17g,%.17g,%.17g,%.17g\n", k, e[k], r.enstrophy[k], r.energy_flux[k],
                         r.enstrophy_flux[k]);
    });
    if (!png_path.empty()) draw_spectrum(csv_path, png_path, e, t);
}

double read_snapshot_time(const std::string& path) {
    handle f = open_for_reading(path);
    const double t = get<double>(f, "time");
    if (!std::isfinite(t)) throw std::runtime_error(path + ": time is not finite");
    return t;
}

bool redraw_spectrum_png(const std::string& csv_path, const std::string& png_path, double t) {
    std::FILE* f = std::fopen(csv_path.c_str(), "r");
    if (!f) return false;
    std::vector<double> e(1, 0.0);  // (e[0]: the mean, not in the file)
    char line[512];
    bool header = true, whole = true;
    while (std::fgets(line, sizeof line, f)) {
        if (header) {
            header = false;
            whole = std::strncmp(line, "k,E,", 4) == 0;
            continue;
        }
        char* end = nullptr;
        const unsigned long long k = std::strtoull(line, &end, 10);
        if (*end != ',' || k != e.size()) {  // (rows k = 1, 2, ... in order, as write_spectrum writes them)
            whole = false;
            break;
        }
        e.push_back(std::strtod(end + 1, nullptr));
    }
    std::fclose(f);
    return whole && e.size() > 1 && draw_spectrum(csv_path, png_path, e, t);
}

}  // namespace eci::cli

// ---- h5_series (h5_series.hpp): a run's rows as HDF5 ----

namespace eci::cli {

void check_hdf5_request(const std::string& path) {
    if (!is_hdf5_path(path)) return;
    // HDF5 needs a file it can seek
    if (names_a_stream(path))
        throw bad_input("--output '" + path + "': HDF5 is written to a regular file, not to a stream, device or FIFO");
}

struct h5_series::impl {
    std::string file, what;
    std::vector<group> groups;
    hid_t id = -1;
    std::vector<hid_t> sets;                // t, then one per group of width > 0
    std::vector<std::vector<double>> rows;  // the buffered rows of each dataset
    std::size_t buffered = 0, written = 0, flush_at = 1;

    [[noreturn]] void fail(const std::string& doing, const std::function<std::string()>& why) const {
        throw run_error("cannot write " + what + ": HDF5 could not " + doing + why() + "; no output was replaced");
    }
    hid_t create(const std::string& name, std::size_t width) {
        // extendible along the rows, chunks of 16 KiB (of a wide state: one row, 2048 columns), so that a short run
        // makes a small file (each chunk is allocated whole) and a long one a few thousand chunks per MiB of rows
        const bool flat = width == 0;  // (t: one dimension)
        const hsize_t w = flat ? 1 : hsize_t(width);
        const hsize_t cols = std::min<hsize_t>(w, 2048), chunk_rows = std::max<hsize_t>(1, 2048 / cols);
        const hsize_t dims[2] = {0, w}, maxdims[2] = {H5S_UNLIMITED, w}, chunk[2] = {chunk_rows, cols};
        handle sp(H5Screate_simple(flat ? 1 : 2, dims, maxdims), H5Sclose, "HDF5 dataspace");
        handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "HDF5 dataset properties");
        H5Pset_obj_track_times(dcpl, false);
        if (H5Pset_chunk(dcpl, flat ? 1 : 2, chunk) < 0) throw std::runtime_error("HDF5 chunks of " + name);
        const hid_t d = H5Dcreate2(id, name.c_str(), H5T_NATIVE_DOUBLE, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT);
        if (d < 0) throw std::runtime_error("HDF5 dataset " + name);
        return d;
    }
    void names(const group& g) {
        if (g.columns.empty() || g.columns.size() != g.width || g.width > max_named) return;
        std::size_t longest = 1;
        for (const std::string& c : g.columns) longest = std::max(longest, c.size());
        std::vector<char> text(longest * g.columns.size(), '\0');
        for (std::size_t i = 0; i < g.columns.size(); ++i) std::copy(g.columns[i].begin(), g.columns[i].end(), &text[i * longest]);
        handle t(H5Tcopy(H5T_C_S1), H5Tclose, "HDF5 string type");
        H5Tset_size(t, longest);
        const hsize_t n = g.columns.size();
        handle sp(H5Screate_simple(1, &n, nullptr), H5Sclose, "HDF5 dataspace");
        handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "HDF5 dataset properties");
        H5Pset_obj_track_times(dcpl, false);
        const std::string name = g.name + "_columns";
        handle d(H5Dcreate2(id, name.c_str(), t, sp, H5P_DEFAULT, dcpl, H5P_DEFAULT), H5Dclose, "HDF5 dataset " + name);
        if (H5Dwrite(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data()) < 0)
            throw std::runtime_error("HDF5 dataset " + name);
        d.close_checked("HDF5 dataset " + name);
    }
    void flush() {
        if (buffered == 0) return;
        const auto why = begin_hdf5_write(file);
        for (std::size_t s = 0; s < sets.size(); ++s) {
            const std::size_t w = rows[s].size() / buffered;
            const bool flat = s == 0;
            const hsize_t extent[2] = {hsize_t(written + buffered), hsize_t(w)};
            if (H5Dset_extent(sets[s], extent) < 0) fail("extend its datasets", why);
            const hid_t fs = H5Dget_space(sets[s]);
            const hsize_t start[2] = {hsize_t(written), 0}, count[2] = {hsize_t(buffered), hsize_t(w)};
            const bool selected = fs >= 0 && H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, nullptr, count, nullptr) >= 0;
            const hid_t ms = H5Screate_simple(flat ? 1 : 2, count, nullptr);
            const bool ok = selected && ms >= 0 &&
                            H5Dwrite(sets[s], H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, rows[s].data()) >= 0;
            if (ms >= 0) H5Sclose(ms);
            if (fs >= 0) H5Sclose(fs);
            if (!ok) fail("write its rows", why);
            rows[s].clear();
        }
        written += buffered;
        buffered = 0;
    }
    void release() {
        for (hid_t s : sets) H5Dclose(s);
        sets.clear();
        if (id >= 0) H5Fclose(id);
        id = -1;
    }
};

h5_series::h5_series(const std::string& file, std::string_view what, std::vector<group> groups,
                     std::vector<attribute> attributes)
    : d_(std::make_unique<impl>()) {
    impl& d = *d_;
    d.file = file;
    d.what = std::string(what);
    d.groups = std::move(groups);
    const auto why = begin_hdf5_write(file);
    d.id = H5Fcreate(file.c_str(), H5F_ACC_TRUNC, untimed_file_properties(), any_attribute_size_access());
    if (d.id < 0) d.fail("create the file", why);
    try {
        put(d.id, "format", std::string("eci run series"));
        put(d.id, "version", std::int64_t(1));
        for (const attribute& a : attributes)
            std::visit([&](const auto& v) { put(d.id, a.name.c_str(), v); }, a.value);
        d.sets.push_back(d.create("t", 0));
        std::size_t row_width = 1;
        for (const group& g : d.groups) {
            if (g.width == 0) continue;
            d.sets.push_back(d.create(g.name, g.width));
            d.names(g);
            row_width += g.width;
        }
        d.rows.resize(d.sets.size());
        // rows buffered up to about 4 MiB (at least one), then appended
        d.flush_at = std::max<std::size_t>(1, (std::size_t(1) << 19) / row_width);
    } catch (const std::runtime_error& e) {
        const std::string reason = why();
        d.release();
        throw run_error("cannot write " + d.what + ": " + e.what() + reason);
    }
}

h5_series::~h5_series() {
    if (d_) d_->release();
}

void h5_series::add(double t, std::span<const std::span<const double>> values) {
    impl& d = *d_;
    d.rows[0].push_back(t);
    std::size_t s = 1;
    for (std::size_t g = 0; g < d.groups.size() && g < values.size(); ++g) {
        if (d.groups[g].width == 0) continue;
        std::vector<double>& r = d.rows[s++];
        const std::span<const double> v = values[g];
        const std::size_t w = d.groups[g].width;
        r.insert(r.end(), v.begin(), v.begin() + std::ptrdiff_t(std::min(w, v.size())));
        r.resize(r.size() + (w - std::min(w, v.size())), std::nan(""));
    }
    if (++d.buffered >= d.flush_at) d.flush();
}

void h5_series::close() {
    impl& d = *d_;
    if (d.id < 0) return;
    d.flush();
    const auto why = begin_hdf5_write(d.file);
    bool ok = true;
    for (hid_t s : d.sets) ok = H5Dclose(s) >= 0 && ok;
    d.sets.clear();
    const bool flushed = ok && H5Fflush(d.id, H5F_SCOPE_LOCAL) >= 0;
    const bool closed = H5Fclose(d.id) >= 0;
    d.id = -1;
    if (!flushed || !closed) d.fail(flushed ? "close the file" : "write the file", why);
}

}  // namespace eci::cli

#include "render/ranks.h"

#include "render/signals.h"

#include <signal.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <functional>
#include <iostream>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>
#include <unistd.h>

#ifdef RAYBUNDLE_WITH_MPI
#include <mpi.h>
#endif

namespace raybundle::render {

namespace {

// The rank count mpirun (Open MPI, MPICH's Hydra, PMIx launchers) put in the
// environment; 0 when the process was not started by one.
long launched_ranks() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"})
        if (const char* v = std::getenv(name)) return std::strtol(v, nullptr, 10);
    if (std::getenv("PMIX_RANK")) return 1;
    return 0;
}

}  // namespace

#ifdef RAYBUNDLE_WITH_MPI

namespace {

// Ranks other than 0 print nothing: their messages would repeat rank 0's.
void silence() {
    const int null = ::open("/dev/null", O_WRONLY);
    if (null < 0) return;
    ::dup2(null, STDOUT_FILENO);
    ::dup2(null, STDERR_FILENO);
    ::close(null);
}

// Rank 0 names the ranks on its host that died (kill -9, the OOM killer): mpirun
// then signals the others, and the reporter, on that signal, finds them gone.
void name_the_dead(int rank, int size) {
    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    long mine[2] = {static_cast<long>(::getpid()), static_cast<long>(std::hash<std::string>{}(host) >> 1)};
    std::vector<long> all(2 * static_cast<std::size_t>(size));
    MPI_Allgather(mine, 2, MPI_LONG, all.data(), 2, MPI_LONG, MPI_COMM_WORLD);
    if (rank != 0 || size < 2) return;
    render::set_signal_reporter([all, size](int) {
        bool gone = false;
        for (int r = 1; r < size; ++r)
            if (all[2 * r + 1] == all[1] && ::kill(static_cast<pid_t>(all[2 * r]), 0) != 0 && errno == ESRCH) {
                std::cerr << "\nraybundle: rank " << r << " of " << size << " (process " << all[2 * r]
                          << ") ended before the run (killed?); the run stops, nothing written\n";
                gone = true;
            }
        return gone;
    });
}

// Once the ranks know how the run ends (a failure agreed on, or the end of main), the
// others exit as they please and mpirun may signal rank 0 for it: neither their deaths
// nor that signal is news then, nor a request to stop.
void end_the_watch() {
    render::set_signal_reporter(nullptr);
    render::set_stoppable(false);
    render::expect_signals();
}

}  // namespace

Ranks::Ranks(int& argc, char**& argv) {
    if (launched_ranks() == 0) return;
    int provided = 0;
    // MPI is called from the main thread alone; the solver's threads never call it.
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    mpi_ = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    if (rank_ != 0) silence();
    // Every rank runs the same command, compared before anything else is exchanged: a
    // rank running `check` or `--version` beside ranks running `solve` would leave them
    // waiting in their first collective.
    std::uint64_t mine = 0xcbf29ce484222325ull, leaders = 0;
    for (int i = 1; i < argc; ++i)  // FNV-1a of the arguments, each with its terminating zero
        for (const char c : std::string(argv[i]) + '\0') mine = (mine ^ static_cast<unsigned char>(c)) * 0x100000001b3ull;
    leaders = mine;
    MPI_Bcast(&leaders, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    int other = leaders != mine ? rank_ : size_, first = size_;
    MPI_Allreduce(&other, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (first == size_) {
        name_the_dead(rank_, size_);
        return;
    }
    // Rank 0 says so before any rank may exit: mpirun ends the other ranks as soon as one
    // exits with an error, and once ended rank 0 before its line was out.
    const std::string message = "rank " + std::to_string(first) + " of " + std::to_string(size_) +
                                " runs another command than rank 0: mpirun must start the same raybundle command on "
                                "every rank";
    if (rank_ == 0) std::cerr << "raybundle: error: " << message << "\n" << std::flush;
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Finalize();
    mpi_ = false;
    throw RankFailed(message, 2);  // said already; the exit code of bad input
}

Ranks::~Ranks() {
    if (!mpi_) return;
    end_the_watch();
    MPI_Finalize();
}

std::string Ranks::library() {
    char version[MPI_MAX_LIBRARY_VERSION_STRING];
    int length = 0;
    MPI_Get_library_version(version, &length);
    std::string v(version, static_cast<std::size_t>(length));
    return "MPI (" + v.substr(0, v.find_first_of(",\n")) + ")";
}

void Ranks::agree(const std::string* failure, int code) const {
    if (!spread()) {
        if (failure) throw RankFailed(*failure, code);
        return;
    }
    const int mine = failure ? rank_ : size_;
    int lowest = size_;
    MPI_Allreduce(&mine, &lowest, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (lowest == size_) return;
    end_the_watch();
    int header[2] = {code, failure ? static_cast<int>(failure->size()) : 0};
    MPI_Bcast(header, 2, MPI_INT, lowest, MPI_COMM_WORLD);
    std::string message(static_cast<std::size_t>(header[1]), '\0');
    if (rank_ == lowest) message = *failure;
    MPI_Bcast(message.data(), header[1], MPI_CHAR, lowest, MPI_COMM_WORLD);
    throw RankFailed(lowest == 0 ? message : "rank " + std::to_string(lowest) + " of " + std::to_string(size_) + ": " + message,
                     header[0]);
}

void Ranks::share_rows(void* data, std::size_t row_bytes, int rows) const {
    agree(nullptr, 0);
    if (!spread() || row_bytes == 0) return;
    // Rank k's rows k, k + R, ... packed in turn, gathered rank after rank, unpacked.
    MPI_Datatype row;
    MPI_Type_contiguous(static_cast<int>(row_bytes), MPI_BYTE, &row);
    MPI_Type_commit(&row);
    std::vector<int> counts(static_cast<std::size_t>(size_)), firsts(static_cast<std::size_t>(size_));
    for (int k = 0, first = 0; k < size_; first += rows_of(k, rows), ++k) {
        counts[static_cast<std::size_t>(k)] = rows_of(k, rows);
        firsts[static_cast<std::size_t>(k)] = first;
    }
    auto* bytes = static_cast<char*>(data);
    std::vector<char> mine(row_bytes * static_cast<std::size_t>(rows_of(rank_, rows)));
    for (int i = 0; i < rows_of(rank_, rows); ++i)
        std::memcpy(&mine[row_bytes * static_cast<std::size_t>(i)], bytes + row_bytes * static_cast<std::size_t>(rank_ + i * size_),
                    row_bytes);
    std::vector<char> all(row_bytes * static_cast<std::size_t>(rows));
    MPI_Allgatherv(mine.data(), rows_of(rank_, rows), row, all.data(), counts.data(), firsts.data(), row, MPI_COMM_WORLD);
    MPI_Type_free(&row);
    for (int k = 0; k < size_; ++k)
        for (int i = 0; i < rows_of(k, rows); ++i)
            std::memcpy(bytes + row_bytes * static_cast<std::size_t>(k + i * size_),
                        &all[row_bytes * static_cast<std::size_t>(firsts[static_cast<std::size_t>(k)] + i)], row_bytes);
}

std::vector<std::vector<char>> Ranks::gather_all(const std::vector<char>& mine) const {
    agree(nullptr, 0);
    if (!spread()) return {mine};
    // The sizes first, as 64-bit counts: every rank sees the same total and refuses alike
    // (MPI counts bytes in an int); memory one rank cannot get is agreed on before the
    // next collective, as every failure is.
    const auto size = static_cast<std::size_t>(size_);
    const auto count = static_cast<long long>(mine.size());
    std::vector<long long> counts(size);
    MPI_Allgather(&count, 1, MPI_LONG_LONG, counts.data(), 1, MPI_LONG_LONG, MPI_COMM_WORLD);
    long long total = 0;
    for (const long long c : counts) total += c;
    if (total > INT_MAX)
        throw std::runtime_error("the ranks' exchange of the scene's contact search would move " + std::to_string(total) +
                                 " bytes, more than MPI's 2 GiB in one exchange: run the scene on one rank, or with a "
                                 "larger patch_size");
    std::vector<int> sizes(counts.begin(), counts.end()), firsts(size, 0);
    for (std::size_t k = 1; k < size; ++k) firsts[k] = firsts[k - 1] + sizes[k - 1];
    std::vector<char> all;
    std::string failure;
    try {
        all.resize(static_cast<std::size_t>(total));
    } catch (const std::bad_alloc&) {
        failure = "out of memory for the ranks' exchange of the scene's contact search (" + std::to_string(total) +
                  " bytes)";
    }
    agree(failure.empty() ? nullptr : &failure, 1);
    MPI_Allgatherv(mine.data(), sizes[static_cast<std::size_t>(rank_)], MPI_BYTE, all.data(), sizes.data(), firsts.data(),
                   MPI_BYTE, MPI_COMM_WORLD);
    std::vector<std::vector<char>> out(size);
    for (std::size_t k = 0; k < size; ++k) out[k].assign(all.begin() + firsts[k], all.begin() + firsts[k] + sizes[k]);
    return out;
}

void Ranks::finish() const {
    agree(nullptr, 0);
    finished_ = true;
}

long Ranks::sum(long value) const {
    agree(nullptr, 0);
    long total = value;
    if (spread()) MPI_Allreduce(&value, &total, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    return total;
}

double Ranks::sum(double value) const {
    agree(nullptr, 0);
    double total = value;
    if (spread()) MPI_Allreduce(&value, &total, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    return total;
}

int Ranks::max(int value) const {
    agree(nullptr, 0);
    int most = value;
    if (spread()) MPI_Allreduce(&value, &most, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return most;
}

std::uint64_t Ranks::from_leader(std::uint64_t value) const {
    agree(nullptr, 0);
    if (spread()) MPI_Bcast(&value, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    return value;
}

void Ranks::weighted_mean(std::vector<double>& values, long n) const {
    agree(nullptr, 0);
    if (!spread()) return;
    const auto size = static_cast<std::size_t>(size_);
    std::vector<long> counts(size);
    MPI_Gather(&n, 1, MPI_LONG, counts.data(), 1, MPI_LONG, 0, MPI_COMM_WORLD);
    std::vector<double> all(leader() ? size * values.size() : 0);
    MPI_Gather(values.data(), static_cast<int>(values.size()), MPI_DOUBLE, all.data(), static_cast<int>(values.size()),
               MPI_DOUBLE, 0, MPI_COMM_WORLD);
    if (leader()) {
        long total = 0;
        for (long c : counts) total += c;
        for (std::size_t i = 0; i < values.size(); ++i) {
            double s = 0.0;
            for (std::size_t k = 0; k < size; ++k) s += static_cast<double>(counts[k]) * all[k * values.size() + i];
            values[i] = total > 0 ? s / static_cast<double>(total) : 0.0;
        }
    }
    MPI_Bcast(values.data(), static_cast<int>(values.size()), MPI_DOUBLE, 0, MPI_COMM_WORLD);
}

#else  // one process: nothing to agree on, nothing to exchange

Ranks::Ranks(int&, char**&) {
    if (const long n = launched_ranks(); n > 1)
        throw std::runtime_error("mpirun started " + std::to_string(n) +
                                 " copies of a raybundle built without MPI: each would run the whole job and write "
                                 "the same files; build with -DRAYBUNDLE_WITH_MPI=ON (libopenmpi-dev), or run one");
}
Ranks::~Ranks() = default;
std::string Ranks::library() { return "none"; }
void Ranks::agree(const std::string* failure, int code) const {
    if (failure) throw RankFailed(*failure, code);
}
void Ranks::share_rows(void*, std::size_t, int) const {}
std::vector<std::vector<char>> Ranks::gather_all(const std::vector<char>& mine) const { return {mine}; }
void Ranks::finish() const { finished_ = true; }
long Ranks::sum(long value) const { return value; }
double Ranks::sum(double value) const { return value; }
int Ranks::max(int value) const { return value; }
std::uint64_t Ranks::from_leader(std::uint64_t value) const { return value; }
void Ranks::weighted_mean(std::vector<double>&, long) const {}

#endif

int Ranks::fail(const std::string& message, int code) {
    // Alone, or past the last exchange (the leader writing): this rank's own failure.
    if (!spread() || finished_) {
        if (leader()) std::cerr << "raybundle: error: " << message << "\n";
        return code;
    }
    try {
        agree(&message, code);
    } catch (const RankFailed& e) {
        if (leader()) std::cerr << "raybundle: error: " << e.what() << "\n";
        return e.code;
    }
    return code;  // not reached: agree() throws for a failure
}

}  // namespace raybundle::render

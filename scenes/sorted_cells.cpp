#include "scenes/sorted_cells.h"

#include "scenes/threads.h"

#include <algorithm>
#include <memory>

namespace raybundle::scenes {

SortedCells::SortedCells(const std::vector<std::vector<std::uint64_t>>& listed, int threads) {
    const std::size_t n = listed.size();
    first.assign(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i) first[i + 1] = first[i] + listed[i].size();
    const std::size_t E = first[n];
    // Not zeroed: every entry is written on the threads before it is read (a serial fill
    // of the megabytes cost more than the sort).
    auto fresh64 = [E] { return std::unique_ptr<std::uint64_t[]>(new std::uint64_t[E]); };
    auto fresh32 = [E] { return std::unique_ptr<std::uint32_t[]>(new std::uint32_t[E]); };
    auto key = fresh64(), key_tmp = fresh64();
    auto at = fresh32(), at_tmp = fresh32(), owner = fresh32();  // listing index, its item
    parallel_chunks(static_cast<int>(n), threads, [&](int i0, int i1) {
        for (int i = i0; i < i1; ++i)
            for (std::size_t s = 0; s < listed[static_cast<std::size_t>(i)].size(); ++s) {
                const std::size_t j = first[static_cast<std::size_t>(i)] + s;
                key[j] = listed[static_cast<std::size_t>(i)][s];
                at[j] = static_cast<std::uint32_t>(j);
                owner[j] = static_cast<std::uint32_t>(i);
            }
    });
    std::uint64_t all_or = 0, all_and = ~std::uint64_t{0};
    for (std::size_t j = 0; j < E; ++j) all_or |= key[j], all_and &= key[j];
    constexpr int kBits = 11;
    constexpr std::size_t kDigits = std::size_t{1} << kBits;
    const int T = static_cast<int>(std::max<std::size_t>(1, std::min<std::size_t>(static_cast<std::size_t>(std::max(1, threads)), E / 65536 + 1)));
    std::vector<std::size_t> count(static_cast<std::size_t>(T) * kDigits);
    auto chunk = [&](int t) { return E * static_cast<std::size_t>(t) / static_cast<std::size_t>(T); };
    for (int shift = 0; shift < 64; shift += kBits) {
        if (((all_or ^ all_and) >> shift & (kDigits - 1)) == 0) continue;  // one digit everywhere
        const auto digit = [shift](std::uint64_t k) { return static_cast<std::size_t>(k >> shift & (kDigits - 1)); };
        std::fill(count.begin(), count.end(), 0);
        run_threads(T, [&](int t) {
            std::size_t* c = &count[static_cast<std::size_t>(t) * kDigits];
            for (std::size_t j = chunk(t); j < chunk(t + 1); ++j) ++c[digit(key[j])];
        });
        // Offsets digit by digit, chunk by chunk within a digit: a stable order.
        std::size_t sum = 0;
        for (std::size_t d = 0; d < kDigits; ++d)
            for (int t = 0; t < T; ++t) {
                std::size_t& c = count[static_cast<std::size_t>(t) * kDigits + d];
                const std::size_t here = c;
                c = sum;
                sum += here;
            }
        run_threads(T, [&](int t) {
            std::size_t* c = &count[static_cast<std::size_t>(t) * kDigits];
            for (std::size_t j = chunk(t); j < chunk(t + 1); ++j) {
                const std::size_t to = c[digit(key[j])]++;
                key_tmp[to] = key[j];
                at_tmp[to] = at[j];
            }
        });
        key.swap(key_tmp);
        at.swap(at_tmp);
    }
    // The runs: a listing starts one where its key differs from the one before. The
    // starts counted per chunk on the threads, then numbered on them from the counts
    // before each chunk (at is a permutation: the writes to run_of are disjoint).
    auto starts = [&](std::size_t j) { return j == 0 || key[j] != key[j - 1]; };
    std::vector<std::size_t> before(static_cast<std::size_t>(T) + 1, 0);
    run_threads(T, [&](int t) {
        std::size_t c = 0;
        for (std::size_t j = chunk(t); j < chunk(t + 1); ++j) c += starts(j) ? 1 : 0;
        before[static_cast<std::size_t>(t) + 1] = c;
    });
    for (int t = 0; t < T; ++t) before[static_cast<std::size_t>(t) + 1] += before[static_cast<std::size_t>(t)];
    run_of.resize(E);
    members.resize(E);
    run_start.resize(before.back() + 1);
    run_threads(T, [&](int t) {
        std::size_t r = before[static_cast<std::size_t>(t)];
        for (std::size_t j = chunk(t); j < chunk(t + 1); ++j) {
            if (starts(j)) run_start[r++] = j;
            run_of[at[j]] = static_cast<std::uint32_t>(r - 1);
            members[j] = owner[at[j]];
        }
    });
    run_start.back() = E;
}

}  // namespace raybundle::scenes

#include "visibility/pair_entries.h"

#include <algorithm>

namespace raybundle::visibility {

namespace {

// Bits needed to write x (0 for 0).
int bit_width(std::uint64_t x) {
    int w = 0;
    for (; x != 0; x >>= 1) ++w;
    return w;
}

int lowest_bit(std::uint64_t x) {  // x != 0
    int b = 0;
    while ((x & 1u) == 0) {
        x >>= 1;
        ++b;
    }
    return b;
}

}  // namespace

void radix_sort(std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& tmp, int low) {
    const std::size_t n = keys.size();
    if (n < 2 || low >= 64) return;
    const std::uint64_t above = ~std::uint64_t{0} << low;
    if (n < 256) {  // a histogram pass would cost more than the sort
        std::sort(keys.begin(), keys.end(), [above](std::uint64_t a, std::uint64_t b) { return (a & above) < (b & above); });
        return;
    }
    // Only the bits that differ between keys need sorting: digits of equal width (at
    // most 12 bits, 4,096 buckets) from the lowest to the highest of them.
    std::uint64_t all_or = 0, all_and = ~std::uint64_t{0};
    for (std::uint64_t k : keys) {
        all_or |= k;
        all_and &= k;
    }
    const std::uint64_t differ = (all_or ^ all_and) & above;
    if (differ == 0) return;
    const int first = lowest_bit(differ), span = bit_width(differ) - first;
    constexpr int kMaxDigit = 12;
    const int passes = (span + kMaxDigit - 1) / kMaxDigit, digit = (span + passes - 1) / passes;
    const std::size_t buckets = std::size_t{1} << digit;
    const std::uint64_t mask = buckets - 1;

    // Every pass's histogram in one read of the keys.
    std::vector<std::size_t> histogram(static_cast<std::size_t>(passes) * buckets, 0);
    for (std::uint64_t k : keys) {
        const std::uint64_t bits = k >> first;
        for (int p = 0; p < passes; ++p) ++histogram[static_cast<std::size_t>(p) * buckets + ((bits >> (p * digit)) & mask)];
    }
    tmp.resize(n);
    for (int p = 0; p < passes; ++p) {
        const int shift = first + p * digit;
        if (((differ >> shift) & mask) == 0) continue;  // the same digit in every key
        std::size_t* offset = &histogram[static_cast<std::size_t>(p) * buckets];
        std::size_t sum = 0;
        for (std::size_t b = 0; b < buckets; ++b) {
            const std::size_t c = offset[b];
            offset[b] = sum;
            sum += c;
        }
        for (std::uint64_t k : keys) tmp[offset[(k >> shift) & mask]++] = k;
        keys.swap(tmp);
    }
}

void entries_from_pairs(std::vector<std::uint64_t>& pairs, std::vector<std::uint64_t>& tmp, double pixel_area,
                        std::vector<TransferEntry>& out) {
    std::uint64_t ids = 0;
    for (std::uint64_t k : pairs) ids |= k >> 32 | (k & 0xffffffffu);
    const int id_bits = bit_width(ids);
    const std::uint64_t id_mask = (std::uint64_t{1} << id_bits) - 1;
    for (std::uint64_t& k : pairs) k = (k >> 32) << id_bits | (k & 0xffffffffu);
    radix_sort(pairs, tmp, 0);
    std::size_t distinct = 0;
    for (std::size_t k = 0; k < pairs.size(); ++k) distinct += k == 0 || pairs[k] != pairs[k - 1];
    const std::size_t old = out.size();
    out.resize(old + distinct);
    TransferEntry* e = out.data() + old;
    for (std::size_t k = 0; k < pairs.size();) {
        std::size_t end = k + 1;
        while (end < pairs.size() && pairs[end] == pairs[k]) ++end;
        *e++ = {static_cast<std::uint32_t>(pairs[k] >> id_bits), static_cast<std::uint32_t>(pairs[k] & id_mask),
                static_cast<double>(end - k) * pixel_area};
        k = end;
    }
}

void entries_from_counts_wide(const std::uint32_t* words, std::uint32_t m, double pixel_area,
                              PairCountScratch& scratch, std::vector<TransferEntry>& out) {
    auto& wide = scratch.wide;
    wide.resize(m);
    for (std::uint32_t j = 0; j < m; ++j)
        wide[j] = {static_cast<std::uint64_t>(words[3 * j]) << 32 | words[3 * j + 1], words[3 * j + 2]};
    std::sort(wide.begin(), wide.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    out.clear();
    out.reserve(m);
    for (const auto& [pair, count] : wide)
        out.push_back({static_cast<std::uint32_t>(pair >> 32), static_cast<std::uint32_t>(pair),
                       static_cast<double>(count) * pixel_area});
}

void entries_from_counts(const std::uint32_t* words, std::uint32_t m, double pixel_area, PairCountScratch& scratch,
                         std::vector<TransferEntry>& out) {
    std::uint32_t ids = 0, counts = 0;
    for (std::uint32_t j = 0; j < m; ++j) {
        ids |= words[3 * j] | words[3 * j + 1];
        counts |= words[3 * j + 2];
    }
    const int id_bits = bit_width(ids), count_bits = bit_width(counts);
    if (2 * id_bits + count_bits > 64) {
        entries_from_counts_wide(words, m, pixel_area, scratch, out);
        return;
    }
    // (At most 63 bits above the count: id_bits is at least 1 where two ids differ, and
    // at 0 every id is 0 and count_bits at most 32.)
    const int source_shift = count_bits, receiver_shift = count_bits + id_bits;
    auto& keys = scratch.keys;
    keys.resize(m);
    for (std::uint32_t j = 0; j < m; ++j)
        keys[j] = static_cast<std::uint64_t>(words[3 * j]) << receiver_shift |
                  static_cast<std::uint64_t>(words[3 * j + 1]) << source_shift | words[3 * j + 2];
    radix_sort(keys, scratch.tmp, count_bits);
    const std::uint64_t id_mask = (std::uint64_t{1} << id_bits) - 1, count_mask = (std::uint64_t{1} << count_bits) - 1;
    out.resize(m);
    TransferEntry* e = out.data();
    for (std::uint64_t k : keys)
        *e++ = {static_cast<std::uint32_t>(k >> receiver_shift), static_cast<std::uint32_t>((k >> source_shift) & id_mask),
                static_cast<double>(k & count_mask) * pixel_area};
}

}  // namespace raybundle::visibility
